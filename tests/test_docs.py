"""The docs' code works as written: every ```python block of README.md and of docs/**/*.md runs, as its own script
in an empty directory, importing the package from this tree.

A block that needs a library the test venv may lack starts with a comment ``# needs: torchrl, tianshou`` and skips
where one of them does not import. Code that is not meant to run goes in a ``text`` or ``bash`` block.
"""

import os
import re
import subprocess
import sys
import textwrap
from importlib.util import find_spec
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^(?P<indent>[ \t]*)```python\n(?P<code>.*?)^(?P=indent)```[ \t]*$", re.MULTILINE | re.DOTALL)
NEEDS = re.compile(r"\A# needs: (?P<modules>[\w., ]+)\n")


def doc_files() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def python_blocks(text: str) -> list[tuple[int, str]]:
    """``(line, code)`` of each ```python block of ``text``: the line of its opening fence, its code dedented."""
    return [(text.count("\n", 0, m.start()) + 1, textwrap.dedent(m.group("code"))) for m in BLOCK.finditer(text)]


BLOCKS = [
    pytest.param(code, id=f"{path.relative_to(ROOT)}:{line}")
    for path in doc_files()
    for line, code in python_blocks(path.read_text())
]


def test_the_blocks_are_found():
    # The README's quick start, and the manual's (its set-up page, the model's example) at least; an indented block
    # (in a list) is found too.
    assert len([block for block in BLOCKS if block.id.startswith("README.md")]) >= 1
    assert len([block for block in BLOCKS if block.id.startswith("docs")]) >= 2
    assert python_blocks("- item\n\n  ```python\n  x = 1\n  ```\n") == [(3, "x = 1\n")]
    assert python_blocks("```bash\nls\n```\n") == []


@pytest.mark.parametrize("code", BLOCKS)
def test_every_python_block_of_the_docs_runs(code, tmp_path):
    needs = NEEDS.match(code)
    if needs:
        for module in needs.group("modules").replace(" ", "").split(","):
            if find_spec(module) is None:
                pytest.skip(f"needs {module}")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        "SDL_VIDEODRIVER": "dummy",
        "SDL_AUDIODRIVER": "dummy",
        "MPLBACKEND": "Agg",
    }
    script = tmp_path / "snippet.py"
    script.write_text(code)
    result = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900, check=False
    )
    assert result.returncode == 0, f"the block fails:\n{code}\n{result.stderr}"
