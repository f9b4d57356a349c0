"""The figures the README and the manual quote are their result files', and the results describe today's settings.

The tests here find every tied figure (``benchmarks/pages.py`` says how a page ties a figure to a result file's cell)
in the README and the manual's pages and compare it with the cell at the precision the page prints; every number of
the README's task and headline tables must be such a figure. Each result file records the commit it ran at
(``Commit:``), and a file whose results follow the repository's settings (the hyperparameters of the learning
benchmark's cells, the main job's block) records a hash of them, which must be today's.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

from benchmarks.pages import NUMBER, TIED, result_cell, written
from tests.test_manual import _section

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
RESULTS = ROOT / "benchmarks" / "results"
PAGES = [ROOT / "README.md", *(path for path in DOCS.rglob("*.md") if "results" not in path.relative_to(DOCS).parts)]
"""The pages that quote results: the README and the manual's own pages (not the result files it shows)."""


def printed(cell: float, number: str) -> float:
    """``cell`` at the precision ``number`` is written with: its decimals, or its mantissa's in ``2.09e-07``."""
    plain = number.replace(",", "")
    mantissa = plain.split("e")[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return float(f"{cell:.{decimals}e}") if "e" in plain else round(cell, decimals)


def tied_figures() -> list[tuple[Path, str, Path, str]]:
    """Every tied figure of :data:`PAGES`: (page, its text, the result file, the address)."""
    return [
        (page, text, (page.parent / target).resolve(), " ".join(address.split()))  # a title may wrap
        for page in PAGES
        for text, target, address in TIED.findall(page.read_text())
    ]


def test_every_tied_figure_equals_its_result_cell_at_its_precision():
    figures = tied_figures()
    assert len(figures) >= 10
    for page, text, result, address in figures:
        assert result.is_relative_to(RESULTS.resolve()) and result.exists(), f"{page.name}: {result}"
        quoted = NUMBER.findall(text.replace("`", ""))
        assert quoted, f"{page.name}: the tied figure {text!r} holds no number"
        cell = float(result_cell(result, address).replace(",", ""))
        figure = float(quoted[0].replace(",", ""))
        assert printed(cell, quoted[0]) == figure, f"{page.name}: {text!r} against {result.name} {address!r}: {cell}"


def test_the_readmes_tables_of_results_quote_only_tied_figures():
    """Every number of the README's headline table, and of the task table's columns of scores, is a tied figure."""
    readme = (ROOT / "README.md").read_text()
    for title, first_quoted in (("The tasks", 3), ("Headline figures", 1)):
        rows = [line for line in _section(readme, title).splitlines() if line.startswith("| ")]
        assert len(rows) >= 4, title
        for line in rows[2:]:
            cells = line.strip().strip("|").split("|")[first_quoted:]
            for cell in cells:
                untied = re.sub(r"\]\([^)]*\)", "]", TIED.sub("", cell))
                assert not NUMBER.findall(untied.replace("`", "")), f"{title}: an untied figure in {cell!r}"


def test_the_pages_written_from_results_are_current():
    """The README's and the manual's task tables follow learning.md (its ladder's order, its figures) and the
    manual's home page is the README's text: what ``python benchmarks/pages.py`` writes."""
    for path, text in written().items():
        assert path.read_text() == text, f"{path.relative_to(ROOT)} is stale: run python benchmarks/pages.py"


def test_every_result_file_names_its_commit():
    files = sorted(RESULTS.rglob("*.md"))
    missing = [path.name for path in files if not re.search(r"^Commit: [0-9a-f]{7}", path.read_text(), re.M)]
    assert not missing, f"result files that do not name the commit they ran at: {missing}"


def _benchmarks():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import _common
        import bench_learning
    finally:
        sys.path.pop(0)
    return _common, bench_learning


def test_every_result_describes_todays_settings():
    """A learning cell's hash of its block and evaluation, and the main job's of its block, are today's: a result
    from older hyperparameters is flagged until it runs again."""
    common, learning = _benchmarks()
    records = sorted((RESULTS / "learning").glob("*/*.json"))
    assert records
    for path in records:
        record = json.loads(path.read_text())
        today = learning.settings_hash(record["trainer"], record["task"], record["budget_times"])
        assert record["settings_hash"] == today, f"{path.relative_to(RESULTS)} ran with other settings: run its cell"
    main_job = (RESULTS / "main_job.md").read_text()
    written = re.search(r"^Settings: sha256 ([0-9a-f]{64})", main_job, re.M)
    assert written and written.group(1) == common.main_job_settings(), "main_job.md ran with other settings"


def test_a_cell_run_in_parts_writes_one_record_of_every_seed(tmp_path, monkeypatch):
    """``cell --seeds 0 1`` then ``--seeds 2``: one record of the three runs; a part with other settings (here
    ``quick``) replaces the record, and a part rerunning a seed replaces that seed's run."""
    _, learning = _benchmarks()

    def runner(task, seeds, quick, times, folder):
        return [{"seed": seed, "steps": 10, "wall_s": 1.0, "success": seed / 10} for seed in seeds]

    monkeypatch.setitem(learning.RUNNERS, "sb3-ppo", runner)
    path = learning.run_cell("sb3-ppo", "upright", [0, 1], tmp_path, quick=False)
    learning.run_cell("sb3-ppo", "upright", [2], tmp_path, quick=False)
    record = json.loads(path.read_text())
    assert [run["seed"] for run in record["runs"]] == [0, 1, 2]
    assert record["settings_hash"] == learning.settings_hash("sb3-ppo", "upright")
    learning.run_cell("sb3-ppo", "upright", [1], tmp_path, quick=False)
    assert [run["seed"] for run in json.loads(path.read_text())["runs"]] == [0, 1, 2]
    learning.run_cell("sb3-ppo", "upright", [3], tmp_path, quick=True)
    assert [run["seed"] for run in json.loads(path.read_text())["runs"]] == [3]
