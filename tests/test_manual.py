"""The manual (mkdocs.yml, docs/) covers what it promises: the public API and every benchmark result.

The strict build itself (``mkdocs build --strict``: links, pages, docstrings that render) runs in .ci/run, in a venv
of the docs extra; these checks need only the package.
"""

from __future__ import annotations

import ast
import inspect
import re
from pathlib import Path

import pytest

import rolling_disk_env
from benchmarks import pages
from rolling_disk_env import constants, dynamics, integrators

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
API_MODULES = (rolling_disk_env, constants, dynamics, integrators)
"""The modules whose top level defines the package's public names."""
DIRECTIVE = re.compile(r"^::: ([\w.]+)$", re.MULTILINE)
"""A mkdocstrings directive: the object it renders."""


def rendered_objects() -> set[str]:
    """The paths that the manual's pages render with ``::: path``."""
    return {match for page in DOCS.rglob("*.md") for match in DIRECTIVE.findall(page.read_text())}


def attribute_docstrings(module) -> dict[str, str]:
    """The docstrings written under a module's constants (``NAME = value`` then a string), by name."""
    tree = ast.parse(inspect.getsource(module))
    docstrings = {}
    for statement, following in zip(tree.body, tree.body[1:]):
        if (
            isinstance(statement, (ast.Assign, ast.AnnAssign))
            and isinstance(following, ast.Expr)
            and isinstance(following.value, ast.Constant)
            and isinstance(following.value.value, str)
        ):
            targets = statement.targets if isinstance(statement, ast.Assign) else [statement.target]
            docstrings.update({target.id: following.value.value for target in targets if isinstance(target, ast.Name)})
    return docstrings


@pytest.mark.parametrize("name", rolling_disk_env.__all__)
def test_every_public_name_has_a_docstring(name):
    """The API reference is generated from the docstrings: a public name without one would be missing from it."""
    obj = getattr(rolling_disk_env, name)
    if inspect.isclass(obj) or inspect.isfunction(obj):
        assert inspect.getdoc(obj), f"rolling_disk_env.{name} has no docstring"
    else:
        docstrings = [attribute_docstrings(module).get(name) for module in API_MODULES]
        assert any(docstrings), f"rolling_disk_env.{name} has no docstring under its assignment"


@pytest.mark.parametrize("name", rolling_disk_env.__all__)
def test_every_public_name_is_in_the_api_reference(name):
    """``::: rolling_disk_env`` renders the names the package's ``__init__`` binds; the envs, which it provides
    lazily, need their own directive."""
    rendered = rendered_objects()
    assert "rolling_disk_env" in rendered
    source = inspect.getsource(rolling_disk_env)
    bound = re.search(rf"^\s+{name},$|^{name}\b.*=|import .*\b{name}\b", source, re.M)
    assert bound or any(path.endswith(f".{name}") for path in rendered), f"no page renders rolling_disk_env.{name}"


def test_every_benchmark_result_is_a_page():
    """Performance shows every benchmark's tables and charts: each result file is a page of the site's nav."""
    nav = (ROOT / "mkdocs.yml").read_text()
    folder = ROOT / "benchmarks" / "results"
    results = sorted(path.relative_to(folder).as_posix() for path in folder.rglob("*.md"))  # other CPUs' in folders
    assert results
    missing = [name for name in results if f"results/{name}" not in nav]
    assert not missing, f"benchmark results missing from mkdocs.yml's nav: {missing}"
    assert (DOCS / "results").resolve() == (ROOT / "benchmarks" / "results").resolve()


def test_readme_is_a_front_door():
    """The README stays short (the manual holds the rest), and every file it links or shows exists."""
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 120
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", readme)
    local = [target for target in targets if "://" not in target]
    assert local
    missing = [target for target in local if not (ROOT / target).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"


def _section(text: str, title: str) -> str:
    """The body of the Markdown section ``## title``."""
    start = text.index(f"## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start : None if end < 0 else end]


def test_the_readme_set_up_commands_are_the_ones_ci_runs():
    """The README's test command is the one ``.ci/run`` runs, and each extra the set-up table installs exists."""
    readme = (ROOT / "README.md").read_text()
    commands = re.findall(r"^\| [^|]+ \| `([^`]+)` \|$", _section(readme, "Set-up: the two commands"), re.M)
    assert len(commands) == 4  # the main job, the suite, the main job with torch's CPU build, the GPU
    ci = (ROOT / ".ci" / "run").read_text()
    test_command = next(command for command in commands if "pytest" in command)
    assert f"\n{test_command}\n" in ci, f"the README's test command {test_command!r} is not a line of .ci/run"
    extras = set(re.findall(r'-e "\.\[(\w+)\]"', " ".join(commands)))
    assert extras == {"train", "test", "gpu"}
    declared = (ROOT / "pyproject.toml").read_text()
    assert all(re.search(rf"^{extra} = \[", declared, re.M) for extra in extras)
    assert all(command.startswith("pip install torch==2.13.0 ") for command in commands)
    cpu_only = next(command for command in commands if "download.pytorch.org" in command)
    assert cpu_only.startswith("pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu && ")
    assert cpu_only.endswith(' && pip install -e ".[train]" && python train.py')


def test_the_manuals_home_is_the_readme():
    """One text for both front doors: ``docs/index.md`` is the README's text (``benchmarks/pages.py``'s
    ``home_page``), then its own section on the manual (``python benchmarks/pages.py`` rewrites it)."""
    home = (DOCS / "index.md").read_text()
    assert home.startswith(pages.home_page((ROOT / "README.md").read_text()) + pages.ABOUT + "\n")
