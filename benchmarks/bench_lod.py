"""Level of detail: the reduced lean model (theta, dphi, dtheta, dpsi) against the full 8-state model.

``python benchmarks/bench_lod.py [--quick] [--out DIR]`` writes ``level_of_detail.md`` to DIR (default
``benchmarks/results``).

RK4 at the env's dt = 0.02 s from the paper's scenario 1, medians of 7 runs (3 with ``--quick``): an episode (500
steps) through ``rd.simulate(..., model="lean")`` and ``model="full"``; one step of one disk through
``engine.advance`` on a row of 4 and a row of 8 (the call's overhead included); one step of N = 4096 disks through
``engine.advance``, per disk. Agreement: the largest difference between the lean model and the lean part of the full
model, both stepped by ``engine.advance`` for 500 steps from scenario 1 and 64 random states (seed 0) under random
torques (uniform in [-2, 2] N m, per disk and step), compared while both stay in the model's domain.
"""

from __future__ import annotations

import time

import numpy as np
from _common import arguments, median_seconds, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env import engine
from rolling_disk_env.dynamics import LEAN_INDICES

DT, STEPS = 0.02, 500
RK4 = engine.METHODS.index("rk4")
SCENARIO_1 = np.array([2.0, 0.0, 0.0, 0.1, 0.0, 2.5, 0.0, 0.0])
SIZES = {"full": 8, "lean": 4}


def rows(model: str, states: np.ndarray) -> dict:
    """The arguments of ``engine.advance`` for the rows of ``states`` (full states) on ``model``."""
    n = states.shape[0]
    x = states if model == "full" else states[:, LEAN_INDICES]
    return {
        "states": np.ascontiguousarray(x),
        "torques": np.zeros((n, 2)),
        "disks": np.tile(np.array(rd.DiskParams().constants), (n, 1)),
        "sizes": np.full(n, DT),
        "status": np.zeros(n, dtype=np.int8),
    }


def advance(a: dict) -> None:
    engine.advance(RK4, a["states"], a["torques"], a["disks"], DT, a["sizes"], 1e-6, 1e-8, a["status"])


def costs(repeat: int) -> dict[str, tuple[float, float, float]]:
    """Per model: (seconds per simulate episode, seconds per one-disk advance, seconds per disk-step at N = 4096)."""
    result = {}
    for model in SIZES:
        x0 = SCENARIO_1 if model == "full" else SCENARIO_1[list(LEAN_INDICES)]
        rd.simulate(x0, STEPS * DT, DT, model=model)
        episode = median_seconds(lambda x0=x0, model=model: rd.simulate(x0, STEPS * DT, DT, model=model), 1, repeat)
        one = rows(model, SCENARIO_1[None])
        advance(one)
        single = median_seconds(lambda one=one: advance(one), 20_000, repeat)
        many = rows(model, np.tile(SCENARIO_1, (4096, 1)))
        advance(many)
        batch = median_seconds(lambda many=many: advance(many), 50, repeat) / 4096
        result[model] = (episode, single, batch)
    return result


def agreement() -> tuple[float, int, int]:
    """(largest |lean - lean part of full| while both are in the domain, disks compared, disks that left it)."""
    rng = np.random.default_rng(0)
    starts = np.zeros((64, 8))
    starts[:, 3] = rng.uniform(-0.3, 0.3, 64)
    starts[:, 5:] = rng.uniform([1, -1, -1], [4, 1, 1], (64, 3))
    starts = np.vstack([SCENARIO_1, starts])
    torques = rng.uniform(-2, 2, (STEPS, len(starts), 2))
    full, lean = rows("full", starts), rows("lean", starts)
    inside = np.ones(len(starts), dtype=bool)
    worst = 0.0
    for u in torques:
        full["torques"][:] = lean["torques"][:] = u
        advance(full)
        advance(lean)
        inside &= (full["status"] == engine.RUNNING) & (lean["status"] == engine.RUNNING)
        difference = np.abs(lean["states"] - full["states"][:, LEAN_INDICES]).max(axis=1)
        worst = max(worst, float(np.max(difference[inside], initial=0.0)))
    return worst, len(starts), int(np.sum(~inside))


def main() -> None:
    args = arguments(__doc__)
    repeat = 3 if args.quick else 7
    cost = costs(repeat)
    start = time.perf_counter()
    difference, disks, left = agreement()
    seconds = time.perf_counter() - start
    labels = (
        ("`rd.simulate`, ms per episode", 1e3, ".2f"),
        ("`engine.advance`, one disk, us per step", 1e6, ".2f"),
        ("`engine.advance`, N = 4096, ns per disk-step", 1e9, ".0f"),
    )
    table_rows = [
        [
            label,
            f"{cost['full'][k] * scale:{spec}}",
            f"{cost['lean'][k] * scale:{spec}}",
            f"{cost['full'][k] / cost['lean'][k]:.2f}",
        ]
        for k, (label, scale, spec) in enumerate(labels)
    ]
    outcome = (
        "0 (bitwise equal: the generated lean equations do the full model's arithmetic)"
        if difference == 0
        else f"{difference:.1e} (round-off, amplified along unstable trajectories)"
    )
    write_markdown(
        "level_of_detail",
        "Level of detail: lean model against full model (RK4, dt = 0.02 s)",
        "python benchmarks/bench_lod.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            table(["cost", "full (8 states)", "lean (4 states)", "full / lean"], table_rows),
            "",
            f"Largest |lean - lean part of full| over {disks} episodes of {STEPS} steps with random torques: "
            f"{outcome}; {left} of the {disks} disks left the model's domain (fell flat) and were compared until then; "
            f"computed in {seconds:.1f} s.",
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
