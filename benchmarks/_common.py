"""Shared by the benchmark scripts: the command line, timing with medians, the machine's description, and writing
results."""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
"""The repository: on the import path, so that the scripts run as ``python benchmarks/<script>.py`` import its
``agents`` package (the training settings, the baselines)."""
if str(ROOT) not in sys.path:
    sys.path.append(str(ROOT))
RESULTS = Path(__file__).parent / "results"
"""Where the committed results live, the default of every script's ``--out``."""
START_LOAD = os.getloadavg()[0]
"""The machine's 1-minute load average when the script started (above 0.5: another job shared the cores)."""


def arguments(doc: str, **extra: dict) -> argparse.Namespace:
    """The command line of a benchmark script: ``--quick`` (a smoke run in seconds), ``--out DIR`` (default
    ``benchmarks/results``), plus ``extra`` options (name: ``add_argument`` keywords). ``doc`` is the script's
    docstring; its first line is the help's description."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run: small sizes, few repeats, seconds")
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder for the results (default: %(default)s)")
    for name, kwargs in extra.items():
        parser.add_argument(f"--{name}", **kwargs)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    from agents import show_compiling

    show_compiling()  # the lines that say when the kernels compile
    return args


def median_seconds(call: Callable[[], object], number: int, repeat: int = 7) -> float:
    """Median over ``repeat`` runs of the time of one call (s), each run timing ``number`` calls."""
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            call()
        runs.append((time.perf_counter() - start) / number)
    return statistics.median(runs)


def medians_in_turns(runs: dict[str, Callable[[], float]], repeats: int) -> dict[str, float]:
    """Calls every run of ``runs`` (each returns the quantity it measured) once per repeat, in turn, so that a slow
    spell of the shared machine hits all of them alike; the median of each."""
    samples = {name: [] for name in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            samples[name].append(run())
    return {name: statistics.median(values) for name, values in samples.items()}


def cpu_flags() -> set[str]:
    """The CPU's feature flags as Linux lists them (``/proc/cpuinfo``; empty elsewhere)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return set()
    return next((set(line.split(":", 1)[1].split()) for line in text.splitlines() if line.startswith("flags")), set())


def vector_extension(features: set[str]) -> str:
    """The widest x86 vector extension among CPU ``features`` (``/proc/cpuinfo`` flags or LLVM's ``+avx2`` names):
    AVX-512 (8 doubles a vector), AVX2 (4) or SSE2 (2, the x86-64 baseline and the width of ARM's NEON)."""
    names = {feature.lstrip("+") for feature in features}
    return "AVX-512" if "avx512f" in names else "AVX2" if "avx2" in names else "SSE2"


def cpu() -> str:
    """The CPU (model, and its widest vector extension) and the code numba generates for it: for the host, or for
    the target that ``NUMBA_CPU_NAME`` and ``NUMBA_CPU_FEATURES`` name (how AVX2 code is measured on an AVX-512
    host)."""
    model = platform.processor() or platform.machine()
    try:
        text = Path("/proc/cpuinfo").read_text()
        model = next(line.split(":", 1)[1].strip() for line in text.splitlines() if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    host = vector_extension(cpu_flags())
    target = os.environ.get("NUMBA_CPU_NAME")
    if target and target != "host":
        features = set(os.environ.get("NUMBA_CPU_FEATURES", "").split(","))
        code = f"numba compiled for `{target}` ({vector_extension(features)})"
    else:
        code = f"numba compiled for the host ({host})"
    return f"{model}, {host}{'' if host == 'AVX-512' else ', no AVX-512'}; {code}"


def machine() -> str:
    """A markdown line naming the CPU (:func:`cpu`), the versions that matter to the numbers, and
    :data:`START_LOAD`."""
    versions = ", ".join(
        f"{name} {metadata.version(name)}"
        for name in ("numpy", "numba", "scipy", "gymnasium", "stable-baselines3", "torch")
        if _installed(name)
    )
    return (
        f"Machine: {cpu()}; {os.cpu_count()} cores, Python {sys.version.split()[0]}, {versions}; "
        f"load average {START_LOAD:.1f} at the start; {time.strftime('%Y-%m-%d')}."
    )


def _installed(name: str) -> bool:
    try:
        metadata.version(name)
    except metadata.PackageNotFoundError:
        return False
    return True


def commit() -> str:
    """The checkout's commit, with ``-dirty`` where files it tracks have changes."""

    def git(*args):
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()

    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + ("-dirty" if git("status", "--porcelain", "--untracked-files=no") else "")


def settings_hash(settings: object) -> str:
    """The sha256 of ``settings`` (JSON), what a result records of the repository's settings it ran with
    (``tests/test_results.py`` checks that they are today's)."""
    return hashlib.sha256(json.dumps(settings, sort_keys=True, default=str).encode()).hexdigest()


def main_job_settings() -> str:
    """:func:`settings_hash` of what the main job's wall time follows: its hyperparameter block (``upright`` in
    ``agents/hyperparams/ppo.yml``)."""
    import rolling_disk_env as rd
    from agents.training import HYPERPARAMS, load_hyperparams

    return settings_hash(load_hyperparams(HYPERPARAMS / "ppo.yml", rd.TASK_IDS["upright"]))


def write_markdown(
    name: str, title: str, command: str, sections: list[str], out: Path = RESULTS, settings: str | None = None
) -> Path:
    """Writes ``<out>/<name>.md``: a title, how to reproduce, the machine, the commit it ran at (and ``settings``, a
    :func:`settings_hash`, with what it hashes), then the sections."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name}.md"
    ran = [f"Commit: {commit()}.", *([f"Settings: sha256 {settings}."] if settings else [])]
    body = [f"# {title}", "", f"Reproduce: `{command}`", "", machine(), "", *ran, "", *sections]
    path.write_text("\n".join(body).rstrip() + "\n")
    print(path.read_text())
    return path


def table(header: list[str], rows: list[list[object]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


TARGETS = {
    "host": {},
    "AVX2 (haswell)": {
        "NUMBA_CPU_NAME": "haswell",
        "NUMBA_CPU_FEATURES": "+avx,+avx2,+fma,+f16c,+bmi,+bmi2,+popcnt,+sse4.2,+cx16,+movbe",
    },
    "x86-64 baseline (SSE2)": {"NUMBA_CPU_NAME": "x86-64", "NUMBA_CPU_FEATURES": ""},
}
"""Compile targets: numba's environment variables for each (``host``: none set). ``haswell``'s features give AVX2
code on any x86-64 host, AVX-512 ones included; the x86-64 baseline is SSE2 (two doubles a vector, the width of
ARM's NEON)."""


def in_target(script: str, target: str, flags: list[str]) -> object:
    """Runs ``script`` with ``flags`` in a fresh Python compiled for ``target`` (a key of :data:`TARGETS`: numba reads
    its target when it starts) and returns the JSON value of the last line it prints."""
    command = [sys.executable, script, *flags]
    result = subprocess.run(command, env={**os.environ, **TARGETS[target]}, capture_output=True, text=True, check=False)
    if result.returncode:
        raise RuntimeError(f"the {target} run failed:\n{result.stderr[-3000:]}")
    return json.loads(result.stdout.splitlines()[-1])
