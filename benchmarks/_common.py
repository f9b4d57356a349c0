"""Shared by the benchmark scripts: timing with medians, the machine's description, and writing results."""

from __future__ import annotations

import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

RESULTS = Path(__file__).parent / "results"


def median_seconds(call: Callable[[], object], number: int, repeat: int = 7) -> float:
    """Median over ``repeat`` runs of the time of one call (s), each run timing ``number`` calls."""
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            call()
        runs.append((time.perf_counter() - start) / number)
    return statistics.median(runs)


def machine() -> str:
    """A markdown line naming the machine and the versions that matter to the numbers."""
    versions = ", ".join(
        f"{name} {metadata.version(name)}" for name in ("numpy", "scipy", "gymnasium", "torch") if _installed(name)
    )
    cpu = platform.processor() or platform.machine()
    return (
        f"Machine: {cpu}, {os.cpu_count()} cores, Python {sys.version.split()[0]}, {versions}; "
        f"{time.strftime('%Y-%m-%d')}."
    )


def _installed(name: str) -> bool:
    try:
        metadata.version(name)
    except metadata.PackageNotFoundError:
        return False
    return True


def write_markdown(name: str, title: str, command: str, sections: list[str]) -> Path:
    """Writes ``results/<name>.md``: a title, how to reproduce, the machine, then the sections."""
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / f"{name}.md"
    body = [f"# {title}", "", f"Reproduce: `{command}`", "", machine(), "", *sections]
    path.write_text("\n".join(body).rstrip() + "\n")
    print(path.read_text())
    return path


def table(header: list[str], rows: list[list[object]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)
