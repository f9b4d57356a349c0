"""Level of detail: the reduced lean model (theta, dphi, dtheta, dpsi) against the full 8-state model.

``python benchmarks/bench_lod.py`` writes ``benchmarks/results/level_of_detail.md``: RK4 cost per step and per
episode (500 steps of 0.02 s) on the scalar path and the batched path (N = 4096), and the largest difference
between the lean model and the lean part of the full model over the episode, from scenario 1 and from 64 random
states (seed 0), with random torques held for each step.
"""

from __future__ import annotations

import time

import numpy as np
from _common import median_seconds, table, write_markdown

from rolling_disk_env.dynamics import DEFAULT_PARAMS, FULL_MODEL, LEAN_INDICES, LEAN_MODEL
from rolling_disk_env.integrators import rk4_batched, workspace

DT, STEPS = 0.02, 500


def episode_seconds(model, x0) -> tuple[float, float]:
    """(seconds per step, seconds per episode), scalar path."""
    args = (0.3, -0.5, *DEFAULT_PARAMS.constants)
    x = list(x0)
    step = median_seconds(lambda: model.scalar_rk4(x, DT, *args), 20_000)

    def episode():
        y = list(x0)
        for _ in range(STEPS):
            y = model.scalar_rk4(y, DT, *args)

    return step, median_seconds(episode, 20)


def batched_seconds(model, x0, n=4096) -> float:
    x = np.tile(np.asarray(x0, dtype=float)[:, None], (1, n))
    work = workspace(x.shape)
    torque = np.zeros(n)
    return median_seconds(
        lambda: rk4_batched(model.batched, x, DT, (torque, torque, *DEFAULT_PARAMS.constants), work), 50
    )


def agreement() -> float:
    rng = np.random.default_rng(0)
    starts = np.zeros((64, 8))
    starts[:, 3] = rng.uniform(-0.3, 0.3, 64)
    starts[:, 5:] = rng.uniform([1, -1, -1], [4, 1, 1], (64, 3))
    starts = np.vstack([[2, 0, 0, 0.1, 0, 2.5, 0, 0], starts])
    torques = rng.uniform(-2, 2, (STEPS, 2))
    worst = 0.0
    for x0 in starts:
        full, lean = list(x0), [x0[i] for i in LEAN_INDICES]
        for u in torques:
            args = (u[0], u[1], *DEFAULT_PARAMS.constants)
            full, lean = FULL_MODEL.scalar_rk4(full, DT, *args), LEAN_MODEL.scalar_rk4(lean, DT, *args)
            worst = max(worst, float(np.max(np.abs(np.array(lean) - np.array(full)[list(LEAN_INDICES)]))))
    return worst


def main() -> None:
    x0 = [2.0, 0.0, 0.0, 0.1, 0.0, 2.5, 0.0, 0.0]
    y0 = [x0[i] for i in LEAN_INDICES]
    full_step, full_episode = episode_seconds(FULL_MODEL, x0)
    lean_step, lean_episode = episode_seconds(LEAN_MODEL, y0)
    full_batch, lean_batch = batched_seconds(FULL_MODEL, x0), batched_seconds(LEAN_MODEL, y0)
    start = time.perf_counter()
    difference = agreement()
    seconds = time.perf_counter() - start
    rows = [
        ["scalar, us per step", f"{full_step * 1e6:.2f}", f"{lean_step * 1e6:.2f}", f"{full_step / lean_step:.2f}"],
        [
            "scalar, ms per episode",
            f"{full_episode * 1e3:.2f}",
            f"{lean_episode * 1e3:.2f}",
            f"{full_episode / lean_episode:.2f}",
        ],
        [
            "batched N = 4096, us per step",
            f"{full_batch * 1e6:.0f}",
            f"{lean_batch * 1e6:.0f}",
            f"{full_batch / lean_batch:.2f}",
        ],
    ]
    write_markdown(
        "level_of_detail",
        "Level of detail: lean model against full model (RK4, dt = 0.02 s)",
        "python benchmarks/bench_lod.py",
        [
            table(["cost", "full (8 states)", "lean (4 states)", "full / lean"], rows),
            "",
            f"Largest |lean - lean part of full| over 65 episodes of {STEPS} steps with random torques: "
            + (
                "0 (bitwise equal: the generated lean equations do the full model's arithmetic)"
                if difference == 0
                else f"{difference:.1e} (round-off, amplified along unstable trajectories)"
            )
            + f"; computed in {seconds:.1f} s.",
        ],
    )


if __name__ == "__main__":
    main()
