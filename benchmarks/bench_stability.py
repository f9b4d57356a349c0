"""Stability where methods fail: the largest stable step of each fixed-step method, and the loosest stable tolerance
of dopri5, against spin and lean.

``python benchmarks/bench_stability.py [--quick] [--out DIR]`` writes ``stability.md`` and ``stability_map.png`` to
DIR (default ``benchmarks/results``).

A disk starts at the origin with lean theta0 and spin rate dphi0 (dtheta = dpsi = 0) and runs for 10 s, an episode,
through ``rd.simulate``. A run is *stable* when it stays finite and inside the model's domain and its relative energy
drift stays under 1e-3. For the fixed-step methods the map shows the largest stable dt of the grid 0.5 s ... 0.25 ms.
dopri5 has no step to choose: it integrates each control period of the env's 0.02 s in as many steps as its
tolerances need, so its axis is the tolerance, the loosest stable rtol = atol of the grid 1e-2 ... 1e-10. To compare
the two fairly, the last table gives the cost of staying stable, in derivative evaluations per simulated second: RK4
at its largest stable dt (4 / dt) and dopri5 at its loosest stable tolerance (7 per attempted step, counted as in
``bench_accuracy.py``). Cells where the exact solution (dop853, rtol 1e-10) itself leaves the domain within 10 s are
marked "falls": the disk falls flat, at every setting. ``--quick`` runs 3 x 3 cells of the grid for 2 s.
"""

from __future__ import annotations

import numpy as np
from _common import arguments, table, write_markdown
from bench_accuracy import DOPRI5_EVALUATIONS, dopri5_attempts

import rolling_disk_env as rd
from rolling_disk_env.integrators import EVALUATIONS_PER_STEP

SPINS = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0)
LEANS = (0.05, 0.3, 0.6, 0.9, 1.2, 1.4, 1.5)
STEP_GRID = (0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001, 0.0005, 0.00025)
TOLERANCE_GRID = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
FIXED = tuple(EVALUATIONS_PER_STEP)
ADAPTIVE = "dopri5"
DURATION = 10.0
DRIFT_BOUND = 1e-3
ENV_DT = 0.02


def stable_run(x0: np.ndarray, duration: float, method: str, setting: float) -> np.ndarray | None:
    """The output times of a stable run (fixed steps of ``setting`` s, or dopri5 at rtol = atol = ``setting`` over
    control periods of :data:`ENV_DT`), or None."""
    adaptive = method == ADAPTIVE
    kwargs = {"rtol": setting, "atol": setting} if adaptive else {}
    try:
        times, states = rd.simulate(x0, duration, ENV_DT if adaptive else setting, method=method, **kwargs)
    except rd.OutOfDomainError:
        return None
    energies = rd.energy(states)
    return times if np.max(np.abs(energies - energies[0])) / energies[0] < DRIFT_BOUND else None


def loosest_stable(x0: np.ndarray, duration: float, method: str) -> tuple[float, float]:
    """(the largest stable dt, or loosest stable tolerance, of the method's grid; the derivative evaluations per
    simulated second it costs), NaNs if none is stable."""
    for setting in TOLERANCE_GRID if method == ADAPTIVE else STEP_GRID:
        times = stable_run(x0, duration, method, setting)
        if times is None:
            continue
        if method == ADAPTIVE:
            attempts, _ = dopri5_attempts(x0[None], times, setting, setting)
            return setting, DOPRI5_EVALUATIONS * attempts / duration
        return setting, EVALUATIONS_PER_STEP[method] / setting
    return np.nan, np.nan


def falls(x0: np.ndarray, duration: float) -> bool:
    try:
        rd.simulate(x0, duration, 0.1, method="dop853")
    except rd.OutOfDomainError:
        return True
    return False


def cell_text(value: float, fallen: bool, smallest: float) -> str:
    if fallen:
        return "falls"
    return f"< {smallest:g}" if np.isnan(value) else f"{value:g}"


def main() -> None:
    args = arguments(__doc__)
    leans, spins, duration = (LEANS[3:6], SPINS[::3], 2.0) if args.quick else (LEANS, SPINS, DURATION)
    methods = (*FIXED, ADAPTIVE)
    settings = {method: np.full((len(leans), len(spins)), np.nan) for method in methods}
    costs = {method: np.full((len(leans), len(spins)), np.nan) for method in methods}
    fallen = np.zeros((len(leans), len(spins)), dtype=bool)
    for i, theta in enumerate(leans):
        for j, dphi in enumerate(spins):
            x0 = np.array([0.0, 0.0, 0.0, theta, 0.0, dphi, 0.0, 0.0])
            fallen[i, j] = falls(x0, duration)
            if fallen[i, j]:
                continue
            for method in methods:
                settings[method][i, j], costs[method][i, j] = loosest_stable(x0, duration, method)
    chart(settings, fallen, leans, spins, args.out / "stability_map.png")
    header = ["theta0 (rad) \\ dphi0 (rad/s)", *(f"{s:g}" for s in spins)]
    sections = []
    for method, values in settings.items():
        adaptive = method == ADAPTIVE
        smallest = TOLERANCE_GRID[-1] if adaptive else STEP_GRID[-1]
        rows = [
            [f"{theta:g}", *(cell_text(values[i, j], fallen[i, j], smallest) for j in range(len(spins)))]
            for i, theta in enumerate(leans)
        ]
        title = "loosest stable rtol = atol" if adaptive else "largest stable dt (s)"
        sections += [f"## {method}: {title}", "", table(header, rows), ""]
    cost_rows = []
    for i, theta in enumerate(leans):
        cells = []
        for j in range(len(spins)):
            if fallen[i, j]:
                cells.append("falls")
                continue
            fixed, adaptive = costs["rk4"][i, j], costs[ADAPTIVE][i, j]
            cells.append(
                " / ".join("-" if np.isnan(value) else f"{value:.0f}" for value in (fixed, adaptive))
                + ("" if np.isnan(fixed) or np.isnan(adaptive) else f" ({adaptive / fixed:.2f}x)")
            )
        cost_rows.append([f"{theta:g}", *cells])
    sections += [
        "## The cost of staying stable: rk4 / dopri5, derivative evaluations per simulated second (dopri5's ratio "
        "to rk4)",
        "",
        table(header, cost_rows),
        "",
    ]
    write_markdown(
        "stability",
        "Stability map of the integrators",
        "python benchmarks/bench_stability.py",
        [__doc__.split("\n\n", 2)[2].strip(), "", *sections, "![stability map](stability_map.png)"],
        out=args.out,
    )


def chart(settings, fallen, leans, spins, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(settings), figsize=(5.0 * len(settings), 4.6), layout="constrained")
    for ax, (method, values) in zip(axes, settings.items()):
        adaptive = method == ADAPTIVE
        grid = TOLERANCE_GRID if adaptive else STEP_GRID
        shown = np.log10(np.where(fallen, np.nan, np.nan_to_num(values, nan=grid[-1] / 2)))
        image = ax.imshow(
            shown,
            origin="lower",
            cmap="viridis",
            vmin=np.log10(grid[-1] / 2),
            vmax=np.log10(grid[0]),
            aspect="auto",
        )
        for i in range(values.shape[0]):
            for j in range(values.shape[1]):
                if fallen[i, j]:
                    text, colour = "falls", "gray"
                elif np.isnan(values[i, j]):
                    text, colour = "<", "white"
                else:
                    text = f"{values[i, j]:g}"
                    colour = "black" if adaptive or values[i, j] >= ENV_DT else "white"
                ax.text(j, i, text, ha="center", va="center", fontsize=7, color=colour)
        ax.set_xticks(range(len(spins)), [f"{s:g}" for s in spins])
        ax.set_yticks(range(len(leans)), [f"{t:g}" for t in leans])
        ax.set_xlabel("initial spin rate dphi0 (rad/s)")
        ax.set_ylabel("initial lean theta0 (rad)")
        if adaptive:
            ax.set_title(f"{method}: loosest stable rtol = atol\n(control period {ENV_DT} s)", fontsize=9)
            fig.colorbar(image, ax=ax, label="log10 tolerance", shrink=0.8)
        else:
            ax.set_title(
                f"{method}: largest stable dt (s)\n(env dt = {ENV_DT} s; black text: stable at it)", fontsize=9
            )
    fig.colorbar(axes[0].images[0], ax=list(axes[:-1]), label="log10 dt (s)", shrink=0.8)
    fig.savefig(path, dpi=90, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    main()
