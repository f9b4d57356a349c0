"""Work-precision: error against cost for every method of ``simulate``, and fixed RK4 against dopri5 at equal cost
where fixed steps fail.

``python benchmarks/bench_accuracy.py [--quick] [--out DIR]`` writes ``accuracy.md`` and ``work_precision.png`` to
DIR (default ``benchmarks/results``).

Errors against ``dop853`` at rtol = atol = 1e-12, every 0.1 s: centre position (m, max over the run), lean (rad,
max), relative energy drift (max |E - E0| / E0). Costs, per simulated second and per disk: derivative evaluations
(fixed steps: their count per step; dopri5: 7 per attempted step, accepted or rejected, counted by replaying the
engine's step-size control with its compiled step and checked bitwise against ``simulate``'s result; dop853: counted
through the torque callable, which it calls at each evaluation); the compiled engine's wall time (``engine.advance``,
the loop ``simulate`` runs, on 64 copies of the problem so that the call's overhead vanishes; medians of 3, 1 with
``--quick``); and ``simulate``'s own wall time (a Python loop over the output times, with the contact check at each;
dop853 is scipy's integrator on the engine's derivative).

1. Work-precision, every method over its grid (fixed steps: dt; dopri5 and dop853: rtol = atol), output every 0.1 s
   (dopri5 integrates each 0.1 s interval in its own steps, carrying the step size on): the paper's scenario 1
   (10 s) and scenario 2 (6 s), and 16 random states (seed 0: |theta| <= 0.3 rad, dphi in [1, 4], dtheta and dpsi
   in [-1, 1] rad/s, 5 s) run as one batch.
2. Hard states (slow disks near flat, fast spin at large lean; 10 s, no torque): the env's settings, a control period
   of 0.02 s, in which dopri5 takes as many steps as its tolerances need and RK4 takes ``substeps`` equal steps. For
   each pair of tolerances, RK4 gets the number of substeps that costs the same derivative evaluations as dopri5
   spent (rounded, at least 1), and the env's default (RK4, one substep) is the first row.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass

import numpy as np
from _common import arguments, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env import engine
from rolling_disk_env._generated import kernels
from rolling_disk_env.integrators import EVALUATIONS_PER_STEP
from rolling_disk_env.paper import scenarios

FIXED_STEPS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05)
TOLERANCES = {"dopri5": (1e-3, 1e-4, 1e-6, 1e-8, 1e-10), "dop853": (1e-4, 1e-6, 1e-8, 1e-10)}
REFERENCE_TOLERANCE = 1e-12
OUTPUT_DT = 0.1
ENV_DT = 0.02
ENV_DEFAULT = ("rk4", ENV_DT)
COPIES = 64
DOPRI5_EVALUATIONS = 7
HARD = {
    "slow, near flat: theta0 1.2, dphi0 0.5": (0, 0, 0, 1.2, 0, 0.5, 0, 0),
    "slow: theta0 0.9, dphi0 1": (0, 0, 0, 0.9, 0, 1.0, 0, 0),
    "slow, near flat: theta0 1.4, dphi0 2": (0, 0, 0, 1.4, 0, 2.0, 0, 0),
    "fast spin, large lean: theta0 1.2, dphi0 40": (0, 0, 0, 1.2, 0, 40.0, 0, 0),
    "fast spin, near flat: theta0 1.5, dphi0 40": (0, 0, 0, 1.5, 0, 40.0, 0, 0),
}
"""Hard states, (c1, c2, phi, theta, psi, dphi, dtheta, dpsi): the exact disk stays inside the model's domain for
10 s from each (issue 12 names the first two)."""
HARD_DURATION = 10.0
HARD_TOLERANCES = ((1e-4, 1e-6), (1e-6, 1e-8), (1e-8, 1e-10))
"""(rtol, atol) pairs of dopri5 on the hard states; the middle one is the env's default."""


@dataclass
class Run:
    """One run of ``simulate``: its states every :data:`OUTPUT_DT` (None if it failed) and its costs per simulated
    second per disk (evaluations; wall seconds of the engine's loop, NaN for dop853; wall seconds of ``simulate``)."""

    states: np.ndarray | None
    evaluations: float = np.nan
    engine_seconds: float = np.nan
    seconds: float = np.nan
    failure: str = ""


def problems(duration_cap: float) -> dict[str, tuple[np.ndarray, float]]:
    rng = np.random.default_rng(0)
    batch = np.zeros((16, 8))
    batch[:, :2] = rng.uniform(-5, 5, (16, 2))
    batch[:, [2, 4]] = rng.uniform(-np.pi, np.pi, (16, 2))
    batch[:, 3] = rng.uniform(-0.3, 0.3, 16)
    batch[:, 5] = rng.uniform(1, 4, 16)
    batch[:, 6:] = rng.uniform(-1, 1, (16, 2))
    first, second = scenarios()
    return {
        "scenario 1": (np.array(first.state0, dtype=float), min(first.duration, duration_cap)),
        "scenario 2": (np.array(second.state0, dtype=float), min(second.duration, duration_cap)),
        "16 random states (batched)": (batch, min(5.0, duration_cap)),
    }


def reference(x0: np.ndarray, duration: float) -> np.ndarray:
    tolerance = REFERENCE_TOLERANCE
    return rd.simulate(x0, duration, OUTPUT_DT, method="dop853", rtol=tolerance, atol=tolerance)[1]


def errors(states: np.ndarray, exact: np.ndarray) -> tuple[float, float, float]:
    position = float(np.max(np.hypot(*(states[..., :2] - exact[..., :2]).T)))
    lean = float(np.max(np.abs(states[..., 3] - exact[..., 3])))
    energies = rd.energy(states.reshape(-1, 8)).reshape(states.shape[:-1])
    drift = float(np.max(np.abs(energies - energies[0]) / energies[0]))
    return position, lean, drift


def dopri5_attempts(rows: np.ndarray, times: np.ndarray, rtol: float, atol: float) -> tuple[int, np.ndarray]:
    """The dopri5 steps (accepted and rejected) ``simulate`` takes from ``rows`` (N, 8) over ``times`` without
    torque, counted by replaying the loop of ``engine.advance_adaptive`` with its compiled step and step-size rule;
    and the final states of the replay (N, 8)."""
    m, g, r = rd.DiskParams().constants
    attempts, finals = 0, []
    for row in rows:
        x, h = tuple(row), times[1] - times[0]
        for period in np.diff(times):
            t = 0.0
            for _ in range(engine.MAX_ADAPTIVE_SUBSTEPS):
                if t >= period:
                    break
                step = min(h, period - t)
                new, error = kernels.state_dopri5_step(x, step, 0.0, 0.0, m, g, r, rtol, atol)
                h = engine.next_step_size(h, step, error)
                attempts += 1
                if error <= 1.0:
                    t, x = (period if step == period - t else t + step), new
        finals.append(x)
    return attempts, np.array(finals)


def engine_seconds(method: str, rows: np.ndarray, times: np.ndarray, tolerances, repeats: int) -> float:
    """Median wall time (s) of ``engine.advance`` over ``times`` on :data:`COPIES` copies of ``rows``, per copy."""
    code = engine.METHODS.index(method)
    copies = np.tile(rows, (COPIES, 1))
    torques, disks = np.zeros((len(copies), 2)), np.tile(np.array(rd.DiskParams().constants), (len(copies), 1))
    status = np.zeros(len(copies), dtype=np.int8)
    intervals = np.diff(times)
    samples = []
    for _ in range(repeats):
        x, sizes = copies.copy(), np.full(len(copies), intervals[0])
        start = time.perf_counter()
        for interval in intervals:
            engine.advance(code, x, torques, disks, interval, sizes, *tolerances, status)
        samples.append(time.perf_counter() - start)
    return statistics.median(samples) / COPIES


def run(x0, duration: float, method: str, setting, repeats: int, interval: float | None = None) -> Run:
    """``simulate`` from ``x0`` with ``method``: fixed steps of ``setting`` seconds, or adaptive under ``setting``
    (rtol = atol, or a pair (rtol, atol)) with output/control intervals of ``interval`` (default :data:`OUTPUT_DT`);
    its costs and its states every OUTPUT_DT, or the failure."""
    adaptive = method in TOLERANCES
    if adaptive:
        tolerances = (setting, setting) if np.isscalar(setting) else tuple(setting)
        dt, kwargs = interval or OUTPUT_DT, {"rtol": tolerances[0], "atol": tolerances[1]}
    else:
        # The engine's loop takes tolerances; fixed steps ignore them.
        tolerances, dt, kwargs = (1e-6, 1e-8), setting, {}
    disks = 1 if np.ndim(x0) == 1 else len(x0)
    seconds = []
    try:
        for _ in range(repeats):
            start = time.perf_counter()
            times, states = rd.simulate(x0, duration, dt, method=method, **kwargs)
            seconds.append(time.perf_counter() - start)
    except rd.OutOfDomainError as error:
        return Run(None, failure=f"failed at t = {error.time:.2f} s")
    outcome = Run(states[:: max(1, round(OUTPUT_DT / dt))], seconds=statistics.median(seconds) / duration / disks)
    rows = np.atleast_2d(np.asarray(x0, dtype=float))
    if method == "dop853":
        count = [0]

        def counting(t, x):
            count[0] += 1
            return np.zeros((*x.shape[:-1], 2))

        rd.simulate(x0, duration, dt, method=method, torque=counting, **kwargs)
        outcome.evaluations = count[0] / duration  # each evaluation evaluates every disk of the batch once
        return outcome
    if adaptive:
        attempts, finals = dopri5_attempts(rows, times, *tolerances)
        if not np.array_equal(finals, states[-1].reshape(rows.shape)):
            raise RuntimeError("the replay of dopri5's step-size control no longer matches the engine's")
        outcome.evaluations = DOPRI5_EVALUATIONS * attempts / duration / disks
    else:
        outcome.evaluations = EVALUATIONS_PER_STEP[method] * (len(times) - 1) / duration
    outcome.engine_seconds = engine_seconds(method, rows, times, tolerances, repeats) / duration / len(rows)
    return outcome


def settings_label(method: str, setting) -> str:
    if method not in TOLERANCES:
        return f"dt {setting:g}"
    rtol, atol = (setting, setting) if np.isscalar(setting) else setting
    return f"rtol {rtol:g}" if rtol == atol else f"rtol {rtol:g}, atol {atol:g}"


def result_row(label: list[object], outcome: Run, exact: np.ndarray) -> list[object]:
    if outcome.states is None:
        return [*label, outcome.failure, "", "", "", "", ""]
    position, lean, drift = errors(outcome.states, exact)
    engine_us = "" if np.isnan(outcome.engine_seconds) else f"{outcome.engine_seconds * 1e6:.1f}"
    return [
        *label,
        f"{position:.2e}",
        f"{lean:.2e}",
        f"{drift:.2e}",
        f"{outcome.evaluations:.0f}",
        engine_us,
        f"{outcome.seconds * 1e3:.3f}",
    ]


COST_HEADER = [
    "centre error (m)",
    "lean error (rad)",
    "energy drift",
    "evaluations / s",
    "engine us / s",
    "`simulate` ms / s",
]


def work_precision(grids: dict, duration_cap: float, repeats: int) -> tuple[list[list[object]], dict]:
    rows, curves = [], {}
    for name, (x0, duration) in problems(duration_cap).items():
        exact = reference(x0, duration)
        for method, grid in grids.items():
            for setting in grid:
                outcome = run(x0, duration, method, setting, repeats)
                rows.append(result_row([name, method, settings_label(method, setting)], outcome, exact))
                if outcome.states is not None:
                    position, _, drift = errors(outcome.states, exact)
                    wall = outcome.seconds if method == "dop853" else outcome.engine_seconds
                    curves.setdefault((name, method), []).append((outcome.evaluations, wall, position, drift, setting))
    return rows, curves


def hard_states(names, duration: float, repeats: int) -> list[list[object]]:
    rows = []
    for name in names:
        x0 = np.array(HARD[name], dtype=float)
        exact = reference(x0, duration)
        rows.append(
            result_row([name, "rk4", "substeps 1 (env default)"], run(x0, duration, "rk4", ENV_DT, repeats), exact)
        )
        for tolerances in HARD_TOLERANCES:
            adaptive = run(x0, duration, "dopri5", tolerances, repeats, interval=ENV_DT)
            rows.append(result_row([name, "dopri5", settings_label("dopri5", tolerances)], adaptive, exact))
            if adaptive.states is None:
                continue
            per_period = adaptive.evaluations * ENV_DT / EVALUATIONS_PER_STEP["rk4"]
            substeps = max(1, round(per_period))
            fixed = run(x0, duration, "rk4", ENV_DT / substeps, repeats)
            rows.append(result_row([name, "rk4", f"substeps {substeps} (equal cost)"], fixed, exact))
    return rows


def main() -> None:
    args = arguments(__doc__)
    if args.quick:
        grids = {"rk4": (0.01, 0.02), "dopri5": (1e-6,), "dop853": (1e-6,), "euler": (0.01,)}
        duration_cap, repeats, hard = 2.0, 1, list(HARD)[:2]
    else:
        grids = {
            **{method: FIXED_STEPS for method in ("euler", "symplectic_euler", "rk4")},
            **TOLERANCES,
        }
        duration_cap, repeats, hard = np.inf, 3, list(HARD)
    rows, curves = work_precision(grids, duration_cap, repeats)
    hard_rows = hard_states(hard, min(HARD_DURATION, duration_cap), repeats)
    chart(curves, args.out / "work_precision.png")
    write_markdown(
        "accuracy",
        "Work-precision of simulate()",
        "python benchmarks/bench_accuracy.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            "## 1. Work-precision",
            "",
            table(["problem", "method", "setting", *COST_HEADER], rows),
            "",
            "![work-precision](work_precision.png)",
            "",
            f"## 2. Hard states: fixed RK4 against dopri5 at equal cost (control period {ENV_DT} s)",
            "",
            table(["state", "method", "setting", *COST_HEADER], hard_rows),
        ],
        out=args.out,
    )


def chart(curves, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    names = list(dict.fromkeys(name for name, _ in curves))
    methods = list(dict.fromkeys(method for _, method in curves))
    fig, axes = plt.subplots(len(names), 3, figsize=(13, 3.6 * len(names)), squeeze=False)
    colours = dict(zip(("euler", "symplectic_euler", "rk4", "dopri5", "dop853"), ("C3", "C1", "C0", "C4", "C2")))
    panels = (
        (0, 2, "derivative evaluations per simulated second", "centre position error (m)"),
        (1, 2, "wall time per simulated second (ms): engine; dop853, scipy", "centre position error (m)"),
        (0, 3, "derivative evaluations per simulated second", "relative energy drift"),
    )
    for row, name in enumerate(names):
        for column, (x_index, y_index, x_label, y_label) in enumerate(panels):
            ax = axes[row, column]
            scale = 1e3 if x_index == 1 else 1.0
            for method in methods:
                points = curves.get((name, method), [])
                if not points:
                    continue
                xs = [p[x_index] * scale for p in points]
                ys = [max(p[y_index], 1e-17) for p in points]
                ax.loglog(xs, ys, "o-", color=colours[method], label=method, ms=4)
                for p in points:
                    if (method, p[4]) == ENV_DEFAULT:
                        ax.loglog(p[x_index] * scale, max(p[y_index], 1e-17), "*", color="black", ms=14)
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_xlabel(x_label, fontsize=8)
            ax.set_ylabel(y_label)
            ax.set_title(name, fontsize=9)
            ax.grid(alpha=0.3, which="both")
            if row == 0 and column == 0:
                ax.plot([], [], "*", color="black", ms=10, label="env default (rk4, dt 0.02 s)")
                ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
