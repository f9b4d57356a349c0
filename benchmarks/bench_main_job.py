"""The main job's wall time: ``python train.py`` as a user runs it, the whole process, with no compiled kernel cached
and with the cache warm.

``python benchmarks/bench_main_job.py [--quick] [--out DIR] [--against FILE]`` writes ``main_job.md`` and
``main_job.png`` to DIR (default ``benchmarks/results``).

Each run is a fresh process of ``python train.py --out <temporary folder>`` (PPO on ``upright``, the README's main
job), timed from its start to its exit: imports, compiling or loading the kernels, training, the final table over
100 seeded episodes. *Cold*: ``NUMBA_CACHE_DIR`` an empty folder and ``HOME`` an empty one, so that every kernel
compiles (a fresh install's first run); *warm*: the same cache again, :data:`WARM_RUNS` runs, their median. Where
rsl-rl-lib is installed (the ``[gpu]`` extra), ``python train.py --device cpu`` (rsl_rl's PPO on the torch vector
env, 4096 disks, the CPU engine) is timed once after them: its kernels compile in it.
``--against FILE`` (hyperparameters in ``agents/hyperparams/ppo.yml``'s format, e.g. the file before a change of
settings: ``git show <commit>:agents/hyperparams/ppo.yml > FILE``) times ``python train.py --config FILE`` warm too,
each of its runs right after one of the main job's, and gives the ratio of the medians: a comparison that a slow spell
of the shared machine hits on both sides.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from importlib.util import find_spec
from pathlib import Path

from _common import ROOT, arguments, cpu, main_job_settings, table, write_markdown

WARM_RUNS = 3


def run(command: list[str], cache: str, home: str) -> tuple[float, str]:
    """Seconds of one run of ``command`` in a fresh process with ``NUMBA_CACHE_DIR=cache`` and ``HOME=home``, and
    the trained agent's row of its table."""
    environment = {**os.environ, "NUMBA_CACHE_DIR": cache, "HOME": home}
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        result = subprocess.run(
            [sys.executable, "train.py", *command, "--out", out],
            cwd=ROOT,
            env=environment,
            capture_output=True,
            text=True,
            check=False,
        )
        seconds = time.perf_counter() - start
    if result.returncode != 0:
        raise SystemExit(f"bench_main_job.py: train.py {' '.join(command)} failed:\n{result.stderr.strip()}")
    row = next(line for line in result.stdout.splitlines() if line.startswith("| PPO"))
    agent, score, success = (cell.strip() for cell in row.strip("|").split("|"))
    return seconds, f"{agent}: {score}, {success}"


def chart(rows: list[tuple[str, float]], path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 0.6 + 0.5 * len(rows)), facecolor="white")
    names, seconds = zip(*rows)
    ax.barh(names, seconds, color="tab:blue")
    for y, value in enumerate(seconds):
        ax.text(value, y, f" {value:.1f} s", va="center", fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("wall time of the whole process (s)")
    ax.set_title(title, fontsize=8)
    ax.set_xlim(0, max(seconds) * 1.2)
    fig.tight_layout()
    fig.savefig(path, dpi=110, facecolor="white")
    plt.close(fig)


def main() -> None:
    args = arguments(
        __doc__,
        against=dict(type=Path, metavar="FILE", help="hyperparameters to time in turn with the warm main job"),
    )
    if args.against is not None:
        from agents.training import ConfigError, load_hyperparams

        try:
            load_hyperparams(args.against, "RollingDiskUpright-v0")
        except (OSError, ConfigError) as error:
            raise SystemExit(f"bench_main_job.py: --against {args.against}: {error}") from None
    warm_runs = 1 if args.quick else WARM_RUNS
    quick = ["--timesteps", "2048", "--eval-episodes", "10"] if args.quick else []
    jobs = {"python train.py": quick}
    if find_spec("rsl_rl") is not None:
        jobs["python train.py --device cpu"] = ["--device", "cpu", *(["--timesteps", "65536"] if args.quick else [])]
    rows, chart_rows = [], []
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as home:
        for name, command in jobs.items():
            if name == "python train.py":
                cold, row = run(command, cache, home)
                rows.append([f"{name}, cold", "none cached: every kernel compiles", f"{cold:.1f}", row])
                chart_rows.append((f"{name}, cold", cold))
            runs = warm_runs if name == "python train.py" else 1  # rsl_rl's run takes minutes on the CPU
            anchored = name == "python train.py" and args.against is not None
            warm, anchor = [], []
            for _ in range(runs):
                warm.append(run(command, cache, home))
                if anchored:
                    anchor.append(run(["--config", str(args.against.resolve()), *command], cache, home))
            median = statistics.median(seconds for seconds, _ in warm)
            label = (
                f"the same, again: median of {runs}"
                if name == "python train.py"
                else "after those (its 4096-disk kernels compile)"
            )
            rows.append([f"{name}, warm", label, f"{median:.1f}", warm[0][1]])
            chart_rows.append((f"{name}, warm", median))
            if anchored:
                other = statistics.median(seconds for seconds, _ in anchor)
                rows.append(
                    [
                        f"python train.py --config {args.against.name}, warm",
                        f"median of {runs}, each run after one above (the row above: {median / other:.2f}x)",
                        f"{other:.1f}",
                        anchor[0][1],
                    ]
                )
                chart_rows.append((f"--config {args.against.name}, warm", other))

    chart(chart_rows, args.out / "main_job.png", f"the main job, whole process; {cpu()}")
    write_markdown(
        "main_job",
        "The main job's wall time",
        "python benchmarks/bench_main_job.py"
        + (" --quick" if args.quick else "")
        + (f" --against {args.against.name}" if args.against else ""),
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            "![the main job's wall time](main_job.png)",
            "",
            table(["run", "kernel cache", "wall time (s)", "the trained agent in its table: return, success"], rows),
        ],
        args.out,
        settings=main_job_settings(),
    )


if __name__ == "__main__":
    main()
