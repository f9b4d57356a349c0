"""The steady motions of the rolling disk: which are stable, and what friction they need.

``python benchmarks/bench_steady_motions.py`` writes ``benchmarks/results/steady_motions.md`` and
``steady_motions.png``. A steady motion keeps the lean theta, the spin rate dphi and the heading rate dpsi constant;
for each (theta, dpsi) the paper's circle condition gives dphi (``rd.steady_motion``), and the centre runs on a
circle at speed ``v = r (dphi - dpsi sin(theta))``. Its stability is the largest real part of the eigenvalues of the
lean model linearized about it (``rd.steady_motion_eigenvalues``): the disk conserves energy, so a stable motion has
purely imaginary eigenvalues and an unstable one a positive real part. Its contact needs the friction coefficient
``mu = |lambda| / N``: the horizontal force is the centripetal force of the centre's circle, ``m v dpsi``, and the
normal force is the weight, ``m g``, as the centre's height does not change.

The map covers theta >= 0 and dpsi > 0 only: the equations are symmetric under (theta, dpsi) -> (-theta, -dpsi) (the
mirror image, same dphi) and under reversing all rates (dpsi -> -dpsi, dphi -> -dphi), and neither changes the
stability or the friction.
"""

from __future__ import annotations

import math

import numpy as np
from _common import RESULTS, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env.dynamics import DEFAULT_PARAMS, LEAN_LIMIT, normal_force, required_friction, steady_circle
from rolling_disk_env.tasks import TASKS

LEANS = np.linspace(0.0, LEAN_LIMIT - 0.01, 241)
HEADING_RATES = np.geomspace(0.05, 30.0, 241)
SCENARIO_2 = (0.5, 1.0)
"""The paper's scenario 2: theta = 0.5 rad, dpsi = 1 rad/s."""


def is_stable(eigenvalues: np.ndarray) -> bool:
    """No real part above round-off (the disk conserves energy: stable means purely imaginary eigenvalues)."""
    return bool(np.max(eigenvalues.real) <= 1e-7 * max(1.0, np.max(np.abs(eigenvalues))))


def growth_rate(eigenvalues: np.ndarray) -> float:
    """The largest real part (1/s), zero when stable."""
    return 0.0 if is_stable(eigenvalues) else float(np.max(eigenvalues.real))


def closed_form_friction(theta: float, dpsi: float, dphi: float, p: rd.DiskParams) -> float:
    """``m v^2 / R / (m g)`` with ``v = r (dphi - dpsi sin(theta))`` and ``R = v / dpsi``: ``|v dpsi| / g``."""
    return abs(p.radius * (dphi - dpsi * math.sin(theta)) * dpsi) / p.gravity


def steady_state(theta: float, dpsi: float, dphi: float) -> np.ndarray:
    """The full state of the steady motion at the origin, heading 0."""
    return np.array([0.0, 0.0, 0.0, theta, 0.0, dphi, 0.0, dpsi])


def unstable_lean_limit() -> float:
    """The largest lean with an unstable steady motion, from the characteristic polynomial worked out by hand
    (``tests/test_steady_motions.py``): the unstable band of dpsi closes where ``9 cos^2(2 theta) = 20 (1 + 2
    cos^2 theta) sin^2 theta``, i.e. ``76 s^4 - 96 s^2 + 9 = 0`` with ``s = sin(theta)``, whatever g and r."""
    return math.asin(math.sqrt((96 - math.sqrt(96**2 - 4 * 76 * 9)) / (2 * 76)))


def survey(p: rd.DiskParams) -> tuple[np.ndarray, np.ndarray, float]:
    """Growth rate (1/s) and friction coefficient (``required_friction``) on the grid, shape
    (len(HEADING_RATES), len(LEANS)), and the largest difference of the friction from its closed form."""
    growth = np.empty((len(HEADING_RATES), len(LEANS)))
    closed_form = np.empty_like(growth)
    states = np.empty((*growth.shape, 8))
    for i, dpsi in enumerate(HEADING_RATES):
        for j, theta in enumerate(LEANS):
            growth[i, j] = growth_rate(rd.steady_motion_eigenvalues(theta, dpsi, p))
            dphi = rd.steady_motion(theta, dpsi, p)
            closed_form[i, j] = closed_form_friction(theta, dpsi, dphi, p)
            states[i, j] = steady_state(theta, dpsi, dphi)
    friction = required_friction(states.reshape(-1, 8), params=p).reshape(growth.shape)
    difference = float(np.max(np.abs(friction - closed_form) / np.maximum(1.0, closed_form)))
    return growth, friction, difference


def marked_motions(p: rd.DiskParams) -> list[tuple[str, float, float]]:
    """(label, theta, dpsi): the paper's scenario 2 and the circle task's targets."""
    task = TASKS["circle"]()
    low, high = task.radius_range
    motions = [("paper's scenario 2", *SCENARIO_2)]
    for radius in np.linspace(low, high, 4):
        theta, _, dpsi = steady_circle(radius, task.target_speed, p)
        motions.append((f"circle task, R = {radius:g} m at {task.target_speed:g} m/s", theta, dpsi))
    return motions


def rows_of(motions, p: rd.DiskParams) -> list[list[str]]:
    rows = []
    for label, theta, dpsi in motions:
        dphi = rd.steady_motion(theta, dpsi, p)
        eigenvalues = rd.steady_motion_eigenvalues(theta, dpsi, p)
        speed = p.radius * (dphi - dpsi * math.sin(theta))
        verdict = "stable" if is_stable(eigenvalues) else f"unstable, growth {growth_rate(eigenvalues):.3g} 1/s"
        frequency = float(np.max(np.abs(eigenvalues.imag)))
        friction = float(required_friction(steady_state(theta, dpsi, dphi), params=p))
        normal = float(normal_force(steady_state(theta, dpsi, dphi), params=p))
        rows.append(
            [
                label,
                f"{theta:.4f}",
                f"{dphi:.4f}",
                f"{dpsi:.4f}",
                f"{speed:.3f}",
                f"{speed / dpsi:.3f}",
                f"{verdict} (lean oscillates at {frequency:.3f} rad/s)" if frequency > 0 else verdict,
                f"{normal:.4f}",
                f"{friction:.4f}",
                f"{closed_form_friction(theta, dpsi, dphi, p):.4f}",
            ]
        )
    return rows


def main() -> None:
    p = DEFAULT_PARAMS
    growth, friction, difference = survey(p)
    motions = marked_motions(p)
    chart(growth, friction, motions, p)

    unstable_columns = np.flatnonzero((growth > 0).any(axis=0))
    grid_limit = LEANS[unstable_columns[-1]]
    limit = unstable_lean_limit()
    c = math.cos(limit)
    band_closes_at = math.sqrt(6 * p.gravity * math.cos(2 * limit) / (5 * p.radius * c * (1 + 2 * c * c)))
    facts = [
        f"- Straight vertical rolling (theta = dpsi = 0) is stable iff dphi^2 > g / (3 r): dphi > "
        f"{p.critical_spin_rate:.4f} rad/s.",
        f"- A vertical disk pivoting on its diameter (theta = 0, dphi = 0) is stable iff dpsi^2 > 4 g / (5 r): dpsi > "
        f"{math.sqrt(4 * p.gravity / (5 * p.radius)):.4f} rad/s.",
        "- Rolling in place (centre at rest, dpsi^2 cos(theta) = 4 g / r, the orange dashed curve) is stable at every "
        "lean and needs no friction.",
        f"- No steady motion leaning more than {limit:.4f} rad ({math.degrees(limit):.2f} deg) is unstable (the "
        f"unstable band closes there at dpsi = {band_closes_at:.3f} rad/s); on the grid the last unstable column is "
        f"theta = {grid_limit:.4f} rad.",
        f"- Largest growth rate on the grid: {growth.max():.3f} 1/s; friction coefficient on the grid from "
        f"{friction.min():.3g} to {friction.max():.3g}; ``required_friction`` against the closed form "
        f"``|v dpsi| / g``: largest difference {difference:.2g} (absolute where mu < 1, relative above).",
    ]
    header = [
        "motion",
        "theta (rad)",
        "dphi (rad/s)",
        "dpsi (rad/s)",
        "v (m/s)",
        "R (m)",
        "stability",
        "N (N)",
        "mu = required_friction",
        "mu = v dpsi / g",
    ]
    write_markdown(
        "steady_motions",
        "Steady motions: stability and the friction they need",
        "python benchmarks/bench_steady_motions.py",
        [
            __doc__.split("\n\n", 1)[1].strip(),
            "",
            f"Default disk: m = {p.mass:g} kg, r = {p.radius:g} m, g = {p.gravity:g} m/s^2.",
            "",
            "## Marked motions",
            "",
            table(header, rows_of(motions, p)),
            "",
            "## The stability boundary",
            "",
            *facts,
            "",
            "![steady motions](steady_motions.png)",
        ],
    )


def chart(growth, friction, motions, p: rd.DiskParams) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap, LogNorm

    in_place_rates = np.sqrt(4 * p.gravity / (p.radius * np.cos(LEANS)))
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), sharey=True)

    ax = axes[0]
    stable = np.ma.masked_where(growth > 0, np.zeros_like(growth))
    ax.pcolormesh(LEANS, HEADING_RATES, stable, cmap=ListedColormap(["#d9ead3"]), shading="nearest")
    unstable = np.ma.masked_where(growth <= 0, growth)
    image = ax.pcolormesh(LEANS, HEADING_RATES, unstable, cmap="Reds", shading="nearest", vmin=0)
    fig.colorbar(image, ax=ax, label="growth rate: largest real part of the eigenvalues (1/s)")
    ax.contour(LEANS, HEADING_RATES, (growth > 0).astype(float), levels=[0.5], colors="darkred", linewidths=1.0)
    ax.text(0.9, 0.12, "stable\n(purely imaginary eigenvalues)", fontsize=9, color="darkgreen", ha="center")
    ax.text(0.015, 1.6, "unstable", fontsize=9, color="white", fontweight="bold")
    ax.set_title("Stability of the steady motions", fontsize=11)

    ax = axes[1]
    image = ax.pcolormesh(
        LEANS, HEADING_RATES, friction, cmap="viridis", shading="nearest", norm=LogNorm(vmin=1e-2, vmax=1e2)
    )
    fig.colorbar(image, ax=ax, label="friction coefficient needed, |lambda| / N")
    levels = [0.1, 0.3, 1.0, 3.0]
    lines = ax.contour(LEANS, HEADING_RATES, friction, levels=levels, colors="white", linewidths=0.8)
    ax.clabel(lines, fmt="mu = %g", fontsize=8)
    ax.set_title("Friction needed: |lambda| / N = m v dpsi / (m g)", fontsize=11)

    markers = ["*", "o", "s", "^", "D"]
    for ax in axes:
        ax.plot(LEANS, in_place_rates, "--", color="tab:orange", lw=1.6, label="rolling in place (v = 0, mu = 0)")
        for (label, theta, dpsi), marker in zip(motions, markers):
            ax.plot(theta, dpsi, marker, color="black", mfc="gold", ms=11 if marker == "*" else 7, label=label)
        ax.set_yscale("log")
        ax.set_xlim(LEANS[0], LEANS[-1])
        ax.set_ylim(HEADING_RATES[0], HEADING_RATES[-1])
        ax.set_xlabel("lean theta (rad)")
        ax.grid(alpha=0.25, which="both")
    axes[0].set_ylabel("heading rate dpsi (rad/s)")
    axes[0].legend(loc="upper left", fontsize=7.5, framealpha=0.9)
    fig.suptitle(
        f"Steady motions of the disk (m = {p.mass:g} kg, r = {p.radius:g} m): dphi from the circle condition; "
        "above the orange dashed curve the disk leans out of its circle (v < 0)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(RESULTS / "steady_motions.png", dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
