"""The pages that quote the benchmarks' results: how a figure is tied to the cell of a result file, and the parts of
the pages written from results.

A figure quoted from a benchmark is a link to its result file whose title names the table cell it comes from,
``[31.7M](benchmarks/results/env_speed.md "host / 4096 > upright M steps/s")``: the address ``[section / ]row >
column[ #n]`` (no ``|``, which would split a Markdown table's cell) is the ``n``-th number (1 by default) of the cell
in the row whose first cell is ``row`` (or whose first cells are ``a & b & ...``) and the column headed ``column``, in
the first table under a heading that holds ``section``, where one is given, and with that column
(:func:`result_cell`). ``tests/test_results.py`` checks every such figure of the README and the manual.

``python benchmarks/pages.py`` (run by ``bench_learning.py report`` too) rewrites what follows the results: the
README's and the manual's task tables (the learning benchmark's ladder order, default PPO's and the baseline's
success as tied figures; the tasks' descriptions are kept as the tables write them) and the manual's home page, the
README's text (:func:`home_page`). ``tests/test_results.py`` fails while they are not what this writes.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
LEARNING = ROOT / "benchmarks" / "results" / "learning.md"
NUMBER = re.compile(r"(?<![\w.-])-?\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)?")
"""A number as the pages write it: 4.35, 46.015, 2.09e-07, 4,096, -131.4 (not after a hyphen: AVX-512 is a name)."""
TIED = re.compile(r'\[([^\]]+)\]\(([^)\s]+\.md)(?:#[^)\s]*)? "([^"]+)"\)')
"""A tied figure: ``[figure](path/to/result.md "address")``."""
TASK_TABLE = (
    "| task | what the agent must do | success | default PPO (SB3) | classical baseline |\n"
    "| --- | --- | --- | --- | --- |\n"
)
"""The head of the task tables (README.md, docs/tasks/index.md)."""
ABOUT = "## About this manual"
"""The manual's home page's own section, after the README's text."""


def plain(cell: str) -> str:
    """A table cell's text without its Markdown: links' text, no backticks or emphasis."""
    return re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", cell).replace("`", "").replace("*", "").strip()


def tables(text: str) -> list[tuple[str, list[list[str]]]]:
    """The Markdown tables of ``text``: (the last heading before each, its rows of cells, header first)."""
    found, heading, rows = [], "", []
    for line in [*(line.strip() for line in text.splitlines()), ""]:  # a table may be indented in a list
        if line.startswith("|"):
            if not re.match(r"^\|\s*-{3}", line):
                rows.append([plain(cell) for cell in line.strip().strip("|").split("|")])
            continue
        if rows:
            found.append((heading, rows))
            rows = []
        if line.startswith("#"):
            heading = line
    return found


def result_cell(path: Path, address: str) -> str:
    """The number a tied figure's ``address`` names in the result file ``path``, as the file writes it."""
    address, _, index = address.partition(" #")
    place, _, column = (part.strip() for part in address.partition(" > "))
    section, _, row_key = place.rpartition(" / ")
    keys = row_key.split(" & ")
    for heading, rows in tables(path.read_text()):
        if (section and section not in heading) or column not in rows[0]:
            continue
        for row in rows[1:]:
            if row[: len(keys)] == keys:
                numbers = NUMBER.findall(row[rows[0].index(column)].replace("`", ""))
                if len(numbers) < int(index or 1):
                    raise ValueError(f"{path.name}: the cell {address!r} holds {numbers}")
                return numbers[int(index or 1) - 1]
    raise ValueError(f"{path.name} has no cell {address!r}")


def ladder() -> list[list[str]]:
    """The rows of the learning benchmark's table, in its ladder order (by default PPO's success)."""
    return next(rows for heading, rows in tables(LEARNING.read_text()) if "The table" in heading)[1:]


def task_table(text: str, link: str) -> str:
    """``text`` with its task table rewritten from the learning benchmark: ``link``, the path of ``learning.md``
    from the page. Each task's first three cells (its page, what it asks, its success) are kept."""
    start = text.index(TASK_TABLE)
    end = text.index("\n\n", start)
    kept = {
        re.match(r"\| \[`(\w+)`\]", line).group(1): line.split(" | ")[:3]
        for line in text[start + len(TASK_TABLE) : end].splitlines()
    }
    rows = []
    for task, _, baseline, *_ in ladder():
        tied = [
            f'[{result_cell(LEARNING, f"The table / {task} > {column}")}%]({link} "The table / {task} > {column}")'
            for column in ("PPO (SB3)", "baseline")
        ]
        rows.append(" | ".join([*kept.pop(task), tied[0], f"`{baseline.split()[0]}` {tied[1]}"]) + " |")
    if kept:
        raise ValueError(f"tasks of the table that the learning benchmark lacks: {sorted(kept)}")
    return text[:start] + TASK_TABLE + "\n".join(rows) + text[end:]


def home_page(readme: str) -> str:
    """The manual's home page, ``docs/index.md``, up to its own section: the README up to its table of the manual's
    pages (the site has its navigation), with its links made relative to ``docs/`` and its picture captioned."""
    text = readme[: readme.index("## The manual")]
    text = text.replace("](docs/", "](").replace("](benchmarks/results/", "](results/")
    picture = "![The renderer: the circle task's classical controller at t = 6 s](circle_frame.png)"
    caption = (
        "*The env's renderer (`render_mode=\"rgb_array\"`): the circle task's classical controller, `CircleLQR`, at"
        " t = 6 s;\nframe 150 of the `episode.gif` that `python -m agents.evaluate --task circle --agent baseline --out"
        " DIR` writes.*"
    )
    return text.replace(picture, f'{picture}{{ width="600" }}\n\n{caption}')


def written() -> dict[Path, str]:
    """The pages as this module writes them from today's results and README, by path."""
    readme = task_table(README.read_text(), "benchmarks/results/learning.md")
    index = (DOCS / "index.md").read_text()
    return {
        README: readme,
        DOCS / "tasks" / "index.md": task_table((DOCS / "tasks" / "index.md").read_text(), "../results/learning.md"),
        DOCS / "index.md": home_page(readme) + index[index.index(ABOUT) :],
    }


def main() -> None:
    for path, text in written().items():
        if path.read_text() != text:
            path.write_text(text)
            print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
