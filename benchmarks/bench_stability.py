"""Stability where methods fail: the largest stable step of each fixed-step method, against spin and lean.

``python benchmarks/bench_stability.py`` writes ``benchmarks/results/stability.md`` and ``stability_map.png``.
A disk starts at the origin with lean theta0 and spin rate dphi0 (dtheta = dpsi = 0) and runs for 10 s, an episode.
A step dt is *stable* when the run stays finite and inside the model's domain and its relative energy drift stays
under 1e-3; the map shows the largest stable dt of the grid 0.5 s ... 0.25 ms. Cells where the exact solution
(dop853, rtol 1e-10) itself leaves the domain within 10 s are marked "falls": the disk falls flat, at every dt.
"""

from __future__ import annotations

import numpy as np
from _common import RESULTS, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env.integrators import STEPS

SPINS = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0)
LEANS = (0.05, 0.3, 0.6, 0.9, 1.2, 1.4, 1.5)
STEP_GRID = (0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001, 0.0005, 0.00025)
DURATION = 10.0
DRIFT_BOUND = 1e-3
ENV_DT = 0.02


def stable(x0: np.ndarray, method: str, dt: float) -> bool:
    try:
        _, states = rd.simulate(x0, DURATION, dt, method=method)
    except rd.OutOfDomainError:
        return False
    energies = rd.energy(states)
    return bool(np.max(np.abs(energies - energies[0])) / energies[0] < DRIFT_BOUND)


def largest_stable_step(x0: np.ndarray, method: str) -> float | None:
    for dt in STEP_GRID:
        if stable(x0, method, dt):
            return dt
    return None


def falls(x0: np.ndarray) -> bool:
    try:
        rd.simulate(x0, DURATION, 0.1, method="dop853")
    except rd.OutOfDomainError:
        return True
    return False


def main() -> None:
    maps = {method: np.full((len(LEANS), len(SPINS)), np.nan) for method in STEPS}
    fallen = np.zeros((len(LEANS), len(SPINS)), dtype=bool)
    for i, theta in enumerate(LEANS):
        for j, dphi in enumerate(SPINS):
            x0 = np.array([0.0, 0.0, 0.0, theta, 0.0, dphi, 0.0, 0.0])
            fallen[i, j] = falls(x0)
            if fallen[i, j]:
                continue
            for method in STEPS:
                step = largest_stable_step(x0, method)
                maps[method][i, j] = np.nan if step is None else step
    chart(maps, fallen)
    sections = []
    for method, values in maps.items():
        rows = []
        for i, theta in enumerate(LEANS):
            cells = []
            for j in range(len(SPINS)):
                if fallen[i, j]:
                    cells.append("falls")
                elif np.isnan(values[i, j]):
                    cells.append(f"< {STEP_GRID[-1]:g}")
                else:
                    cells.append(f"{values[i, j]:g}")
            rows.append([f"{theta:g}", *cells])
        sections += [
            f"## {method}: largest stable dt (s)",
            "",
            table(["theta0 (rad) \\ dphi0 (rad/s)", *(f"{s:g}" for s in SPINS)], rows),
            "",
        ]
    write_markdown(
        "stability",
        "Stability map of the fixed-step methods",
        "python benchmarks/bench_stability.py",
        [__doc__.split("\n\n", 1)[1].strip(), "", *sections, "![stability map](stability_map.png)"],
    )


def chart(maps, fallen) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(maps), figsize=(5.2 * len(maps), 4.6))
    for ax, (method, values) in zip(axes, maps.items()):
        shown = np.log10(np.where(fallen, np.nan, np.nan_to_num(values, nan=STEP_GRID[-1] / 2)))
        image = ax.imshow(
            shown,
            origin="lower",
            cmap="viridis",
            vmin=np.log10(STEP_GRID[-1] / 2),
            vmax=np.log10(STEP_GRID[0]),
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
                    colour = "black" if values[i, j] >= ENV_DT else "white"
                ax.text(j, i, text, ha="center", va="center", fontsize=7, color=colour)
        ax.set_xticks(range(len(SPINS)), [f"{s:g}" for s in SPINS])
        ax.set_yticks(range(len(LEANS)), [f"{t:g}" for t in LEANS])
        ax.set_xlabel("initial spin rate dphi0 (rad/s)")
        ax.set_ylabel("initial lean theta0 (rad)")
        ax.set_title(f"{method}: largest stable dt (s)\n(env dt = {ENV_DT} s; black text: stable at it)", fontsize=9)
    fig.colorbar(image, ax=axes, label="log10 dt (s)", shrink=0.8)
    fig.savefig(RESULTS / "stability_map.png", dpi=90, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    main()
