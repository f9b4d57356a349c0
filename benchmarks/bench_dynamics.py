"""Cost of one integration step: the scalar path (one disk) and the batched numpy path (N disks).

``python benchmarks/bench_dynamics.py`` writes ``benchmarks/results/dynamics.md``. The scalar RK4 step is set
against a plain-Python floor, the paper's equations hand-written with an RK4 loop, timed in the same run; the
generated RK4 step with its stages written out (``Model.scalar_rk4``, what the env uses) against the generic one.
"""

from __future__ import annotations

import math

import numpy as np
from _common import median_seconds, table, write_markdown

from rolling_disk_env import trig
from rolling_disk_env.dynamics import DEFAULT_PARAMS, FULL_MODEL, LEAN_MODEL
from rolling_disk_env.integrators import EVALUATIONS_PER_STEP, STEPS, rk4_batched, workspace

DT = 0.01
SCENARIO_1 = [2.0, 0.0, 0.0, 0.1, 0.0, 2.5, 0.0, 0.0]
ARGS = (0.0, 0.0, *DEFAULT_PARAMS.constants)


def plain_python_rk4(x, dt, g=9.81, r=1.0):
    """The floor: the paper's state equations typed by hand, one RK4 step, no torques."""

    def f(c1, c2, phi, th, ps, dph, dth, dps):
        st, ct, sp, cp = math.sin(th), math.cos(th), math.sin(ps), math.cos(ps)
        return (
            r * (sp * dph + cp * ct * dth - sp * st * dps),
            r * (-cp * dph + sp * ct * dth + cp * st * dps),
            dph,
            dth,
            dps,
            2 * dph * dth * st / ct + 5 / 3 * dth * dps * ct,
            4 / (5 * r) * g * st - 6 / 5 * dph * dps * ct + dps * dps * st * ct,
            2 * dph * dth / ct,
        )

    k1 = f(*x)
    k2 = f(*[a + 0.5 * dt * b for a, b in zip(x, k1)])
    k3 = f(*[a + 0.5 * dt * b for a, b in zip(x, k2)])
    k4 = f(*[a + dt * b for a, b in zip(x, k3)])
    return [a + dt / 6 * (b + 2 * (c + d) + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4)]


def scalar_rows() -> list[list[object]]:
    floor = median_seconds(lambda: plain_python_rk4(SCENARIO_1, DT), 20_000)
    rows = [["plain-Python floor (hand-written, full)", "rk4", f"{floor * 1e6:.2f}", "1.00"]]
    for model, x in ((FULL_MODEL, SCENARIO_1), (LEAN_MODEL, [0.1, 2.5, 0.0, 0.0])):
        for method, (step, _) in STEPS.items():
            seconds = median_seconds(lambda step=step, model=model, x=x: step(model.scalar, x, DT, ARGS), 20_000)
            rows.append([f"generated, {model.name} model", method, f"{seconds * 1e6:.2f}", f"{seconds / floor:.2f}"])
        seconds = median_seconds(lambda model=model, x=x: model.scalar_rk4(x, DT, *ARGS), 20_000)
        rows.append(
            [
                f"generated, {model.name} model, stages written out",
                "rk4",
                f"{seconds * 1e6:.2f}",
                f"{seconds / floor:.2f}",
            ]
        )
    return rows


def batched_rows(sizes=(1, 16, 256, 4096, 65536)) -> list[list[object]]:
    rows = []
    for n in sizes:
        for model in (FULL_MODEL, LEAN_MODEL):
            x0 = np.array(SCENARIO_1 if model is FULL_MODEL else [0.1, 2.5, 0.0, 0.0])
            x = np.tile(x0[:, None], (1, n))
            work = workspace(x.shape)
            torque = np.zeros(n)
            args = (torque, torque, *DEFAULT_PARAMS.constants)
            number = max(3, 200_000 // (n * 4))
            seconds = median_seconds(
                lambda f=model.batched, x=x, work=work, args=args: rk4_batched(f, x, DT, args, work), number
            )
            rows.append([n, model.name, f"{seconds * 1e6:.1f}", f"{n / seconds / 1e6:.2f}"])
    return rows


def trig_rows(sizes=(64, 512, 1024, 4096, 65536)) -> list[list[object]]:
    """numpy's float64 sine against :mod:`rolling_disk_env.trig`'s (torch's from ``TORCH_FROM`` values up)."""
    rows = []
    for n in sizes:
        angles = np.random.default_rng(0).uniform(-4, 4, n)
        number = max(20, 200_000 // n)
        ours = median_seconds(lambda a=angles: trig.sin(a), number)
        theirs = median_seconds(lambda a=angles: np.sin(a), number)
        rows.append([n, f"{theirs * 1e6:.1f}", f"{ours * 1e6:.1f}", f"{theirs / ours:.2f}"])
    return rows


def main() -> None:
    scalar = scalar_rows()
    batched = batched_rows()
    sines = trig_rows()
    evaluations = ", ".join(f"{method} {count}" for method, count in EVALUATIONS_PER_STEP.items())
    write_markdown(
        "dynamics",
        "Step cost of the generated equations",
        "python benchmarks/bench_dynamics.py",
        [
            "## One disk (scalar path: floats and `math`), one step, median of 7 runs",
            "",
            table(["implementation", "method", "us / step", "ratio to floor"], scalar),
            "",
            f"Right-hand-side evaluations per step: {evaluations}.",
            "",
            "## N disks (batched numpy path), RK4, one step, median of 7 runs",
            "",
            table(["N", "model", "us / step", "M disk-steps / s"], batched),
            "",
            "## Sine of N float64 values: numpy against `rolling_disk_env.trig` (the batched path's), median of 7 runs",
            "",
            table(["N", "numpy.sin us", "trig.sin us", "speed-up"], sines),
        ],
    )


if __name__ == "__main__":
    main()
