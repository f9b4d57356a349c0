"""Work-precision: error against cost for every method of ``simulate``, scalar and batched paths.

``python benchmarks/bench_accuracy.py [--quick]`` writes ``benchmarks/results/accuracy.md`` and
``work_precision.png``. Problems: the paper's scenario 1 (10 s) and scenario 2 (6 s), and 16 random states (seed 0:
|theta| <= 0.3 rad, dphi in [1, 4], dtheta and dpsi in [-1, 1] rad/s, 5 s) run as one batch. Errors against
``dop853`` at rtol = atol = 1e-12: centre position (m, max over the run), lean (rad, max), relative energy drift
(max |E - E0| / E0). Cost: wall time per simulated second (per disk for the batch, median of 3) and right-hand-side
evaluations per simulated second (dop853's counted through the torque callable, called at each evaluation).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _common import RESULTS, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env.integrators import EVALUATIONS_PER_STEP
from rolling_disk_env.paper import scenarios

FIXED_STEPS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05)
TOLERANCES = (1e-4, 1e-6, 1e-8, 1e-10)
ENV_DEFAULT = ("rk4", 0.02)
OUTPUT_DT = 0.1


def problems() -> dict[str, tuple[np.ndarray, float]]:
    rng = np.random.default_rng(0)
    batch = np.zeros((16, 8))
    batch[:, :2] = rng.uniform(-5, 5, (16, 2))
    batch[:, [2, 4]] = rng.uniform(-np.pi, np.pi, (16, 2))
    batch[:, 3] = rng.uniform(-0.3, 0.3, 16)
    batch[:, 5] = rng.uniform(1, 4, 16)
    batch[:, 6:] = rng.uniform(-1, 1, (16, 2))
    first, second = scenarios()
    return {
        "scenario 1": (np.array(first.state0, dtype=float), first.duration),
        "scenario 2": (np.array(second.state0, dtype=float), second.duration),
        "16 random states (batched)": (batch, 5.0),
    }


def errors(states: np.ndarray, reference: np.ndarray) -> tuple[float, float, float]:
    position = float(np.max(np.hypot(*(states[..., :2] - reference[..., :2]).T)))
    lean = float(np.max(np.abs(states[..., 3] - reference[..., 3])))
    energies = rd.energy(states.reshape(-1, 8)).reshape(states.shape[:-1])
    drift = float(np.max(np.abs(energies - energies[0]) / energies[0]))
    return position, lean, drift


def run(x0, duration, method, step, repeats):
    """(states at the output times, median wall time, RHS evaluations) or None if the run left the domain."""
    kwargs = {"rtol": step, "atol": step} if method == "dop853" else {}
    dt = OUTPUT_DT if method == "dop853" else step
    every = 1 if method == "dop853" else max(1, round(OUTPUT_DT / step))
    seconds = []
    try:
        for _ in range(repeats):
            start = time.perf_counter()
            _, states = rd.simulate(x0, duration, dt, method=method, **kwargs)
            seconds.append(time.perf_counter() - start)
    except rd.OutOfDomainError:
        return None
    if method == "dop853":
        count = [0]

        def counting(t, x):
            count[0] += 1
            return np.zeros((*x.shape[:-1], 2))

        rd.simulate(x0, duration, dt, method=method, torque=counting, **kwargs)
        evaluations = count[0]
    else:
        evaluations = EVALUATIONS_PER_STEP[method] * round(duration / step)
    return states[::every], statistics.median(seconds), evaluations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    repeats = 1 if args.quick else 3
    rows, curves = [], {}
    for name, (x0, duration) in problems().items():
        _, reference = rd.simulate(x0, duration, OUTPUT_DT, method="dop853", rtol=1e-12, atol=1e-12)
        disks = 1 if x0.ndim == 1 else x0.shape[0]
        for method in rd.METHODS:
            grid = TOLERANCES if method == "dop853" else FIXED_STEPS
            for step in grid:
                outcome = run(x0, duration, method, step, repeats)
                label = f"rtol {step:g}" if method == "dop853" else f"dt {step:g}"
                if outcome is None:
                    rows.append([name, method, label, "left the domain", "", "", "", ""])
                    continue
                states, seconds, evaluations = outcome
                position, lean, drift = errors(states, reference)
                cost = seconds / duration / disks
                rows.append(
                    [
                        name,
                        method,
                        label,
                        f"{position:.2e}",
                        f"{lean:.2e}",
                        f"{drift:.2e}",
                        f"{cost * 1e3:.3f}",
                        f"{evaluations / duration:.0f}",
                    ]
                )
                curves.setdefault((name, method), []).append((cost, position, lean, drift, step))
    chart(curves)
    write_markdown(
        "accuracy",
        "Work-precision of simulate()",
        "python benchmarks/bench_accuracy.py",
        [
            __doc__.split("\n\n", 1)[1].strip(),
            "",
            table(
                [
                    "problem",
                    "method",
                    "step",
                    "centre error (m)",
                    "lean error (rad)",
                    "energy drift",
                    "ms per simulated s (per disk)",
                    "RHS evaluations per simulated s",
                ],
                rows,
            ),
            "",
            "![work-precision](work_precision.png)",
        ],
    )


def chart(curves) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    names = list(dict.fromkeys(name for name, _ in curves))
    fig, axes = plt.subplots(len(names), 3, figsize=(13, 3.6 * len(names)), squeeze=False)
    colours = dict(zip(rd.METHODS, ("tab:red", "tab:orange", "tab:blue", "tab:green")))
    for row, name in enumerate(names):
        for column, (index, label) in enumerate(
            ((1, "centre position error (m)"), (2, "lean error (rad)"), (3, "relative energy drift"))
        ):
            ax = axes[row, column]
            for method in rd.METHODS:
                points = curves.get((name, method), [])
                if points:
                    cost = [p[0] * 1e3 for p in points]
                    value = [max(p[index], 1e-17) for p in points]
                    ax.loglog(cost, value, "o-", color=colours[method], label=method, ms=4)
                if method == ENV_DEFAULT[0]:
                    for p in points:
                        if p[4] == ENV_DEFAULT[1]:
                            ax.loglog(
                                p[0] * 1e3,
                                max(p[index], 1e-17),
                                "*",
                                color="black",
                                ms=14,
                                label="env default (rk4, dt 0.02 s)",
                            )
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_xlabel("wall time per simulated second (ms)")
            ax.set_ylabel(label)
            ax.set_title(name, fontsize=9)
            ax.grid(alpha=0.3, which="both")
            if row == 0 and column == 0:
                ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(RESULTS / "work_precision.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
