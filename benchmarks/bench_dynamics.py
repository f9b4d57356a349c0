"""Step cost of the compiled engine: RK4 for one disk and for N disks, and the vectorized sine and cosine.

``python benchmarks/bench_dynamics.py [--quick] [--out DIR]`` writes ``dynamics.md`` to DIR (default
``benchmarks/results``). Every time is a median of 7 runs (3 with ``--quick``), disks on the paper's scenario 1
without torques, RK4 steps of 0.01 s on the full model. The loops of a table row in 2. and 3. are timed in turn
within each run, so that a slow spell of the shared machine hits all of them alike.

1. One disk: ``rd.simulate`` (what a user calls: a Python loop over output steps, with the contact check at each)
   and one call of ``engine.advance`` on one row (the model API's compiled loop: the call's overhead included).
2. N disks in one call, per disk-step: ``engine.advance`` on rows (N, 8), the model API's serial loop; the RK4 step
   of the vector env's kernels on a lanes array (one column per disk: the loop the compiler vectorizes, as in the
   fused step of ``_generated/<task>.py``, timed here alone in a loop of this script); and the whole fused step of
   the vector env (``upright`` on one thread: RK4, contact forces, observation, reward, termination) on the same
   disks (scenario 1 precesses at a lean of 0.1 rad: no episode ends, as in a stepped env that resets its disks).
3. The fused step of every task on one thread against the lanes loop of 2., N = 4096, in a fresh process for each
   compile target (``_common.TARGETS``: the host's CPU, AVX2 code, the x86-64 baseline).
4. ``rolling_disk_env.trig.sincos`` in a compiled loop over N angles against libm's ``math.sin`` and ``math.cos``
   in the same loop (numba calls libm, which keeps the loop scalar), and numpy's ``np.sin`` and ``np.cos``, per
   angle (a sine and a cosine), angles uniform in [-4, 4] rad; with the largest difference from libm in ulps.
"""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numba
import numpy as np
from _common import TARGETS, arguments, cpu, in_target, median_seconds, medians_in_turns, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env import engine, trig
from rolling_disk_env._generated import kernels
from rolling_disk_env.envs import batch as envs_batch
from rolling_disk_env.integrators import EVALUATIONS_PER_STEP
from rolling_disk_env.tasks import TASKS

DT = 0.01
FUSED_HEADER = ["task", "fused step, one thread, ns", "RK4 lanes loop ns", "fused / RK4"]
SCENARIO_1 = (2.0, 0.0, 0.0, 0.1, 0.0, 2.5, 0.0, 0.0)
RK4 = engine.METHODS.index("rk4")
DISK = rd.DiskParams().constants


@numba.njit(error_model="numpy")
def rk4_lanes(lanes, dt):
    """One RK4 step of every disk of a lanes array (``engine.LANES`` rows, a column per disk), as the vector env's
    fused step integrates them (component by component: a loop over the tuple would keep the loop scalar)."""
    for i in range(lanes.shape[1]):
        x = kernels.state_rk4_step(
            (lanes[0, i], lanes[1, i], lanes[2, i], lanes[3, i], lanes[4, i], lanes[5, i], lanes[6, i], lanes[7, i]),
            dt,
            lanes[engine.TAU_SPIN, i],
            lanes[engine.TAU_STEER, i],
            lanes[engine.MASS, i],
            lanes[engine.GRAVITY, i],
            lanes[engine.RADIUS, i],
        )
        lanes[0, i], lanes[1, i], lanes[2, i], lanes[3, i] = x[0], x[1], x[2], x[3]
        lanes[4, i], lanes[5, i], lanes[6, i], lanes[7, i] = x[4], x[5], x[6], x[7]


@numba.njit(error_model="numpy")
def sincos_ours(angles, sines, cosines):
    for i in range(angles.size):
        sines[i], cosines[i] = trig.sincos(angles[i])


@numba.njit(error_model="numpy")
def sincos_libm(angles, sines, cosines):
    for i in range(angles.size):
        sines[i] = math.sin(angles[i])
        cosines[i] = math.cos(angles[i])


def sincos_numpy(angles, sines, cosines):
    np.sin(angles, out=sines)
    np.cos(angles, out=cosines)


class Rows:
    """The arguments of ``engine.advance`` for N disks on scenario 1."""

    def __init__(self, n: int):
        self.states = np.tile(np.array(SCENARIO_1), (n, 1))
        self.torques = np.zeros((n, 2))
        self.disks = np.tile(np.array(DISK), (n, 1))
        self.sizes = np.full(n, DT)
        self.status = np.zeros(n, dtype=np.int8)

    def advance(self) -> None:
        engine.advance(RK4, self.states, self.torques, self.disks, DT, self.sizes, 1e-6, 1e-8, self.status)


def one_disk_rows(repeat: int) -> list[list[object]]:
    x0 = np.array(SCENARIO_1)
    steps = 1000
    rd.simulate(x0, steps * DT, DT)
    simulate = median_seconds(lambda: rd.simulate(x0, steps * DT, DT), 1, repeat) / steps
    rows = Rows(1)
    rows.advance()
    advance = median_seconds(rows.advance, 20_000, repeat)
    return [
        [f"`rd.simulate`, {steps} steps", f"{simulate * 1e6:.2f}"],
        ["`engine.advance`, one row per call", f"{advance * 1e6:.2f}"],
    ]


def sample_seconds(call, n: int) -> float:
    """Seconds of one call of ``call``, a loop over n disks, from one sample of calls (about 200,000 disk-steps)."""
    return median_seconds(call, max(3, 200_000 // n), 1)


class FusedStep:
    """The vector env of ``task`` with n disks on one thread, the disks on scenario 1 (as the lanes loop's: it
    precesses at a lean of 0.1 rad, so no episode ends by falling); a call times one sample of its fused step and
    returns the seconds of one step."""

    def __init__(self, task: str, n: int):
        threads_from, envs_batch.THREADS_FROM = envs_batch.THREADS_FROM, n + 1
        self.env = gym.make_vec(rd.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", task=task)
        envs_batch.THREADS_FROM = threads_from
        self.env.reset(seed=0, options={"state": np.tile(SCENARIO_1, (n, 1))})
        self.batch = self.env.unwrapped._batch
        self.out = self.batch.outputs()
        self.actions = np.zeros((n, self.env.single_action_space.shape[0]), dtype=np.float32)
        self.n = n
        self.step()

    def step(self) -> None:
        self.batch.step(self.actions, self.out)

    def __call__(self) -> float:
        return sample_seconds(self.step, self.n)


class LanesLoop:
    """:func:`rk4_lanes` on n disks on scenario 1; a call times one sample and returns the seconds of one loop."""

    def __init__(self, n: int):
        self.lanes = np.zeros((engine.LANES, n))
        self.lanes[:8] = np.array(SCENARIO_1)[:, None]
        self.lanes[engine.MASS : engine.RADIUS + 1] = np.array(DISK)[:, None]
        self.n = n
        self.step()

    def step(self) -> None:
        rk4_lanes(self.lanes, DT)

    def __call__(self) -> float:
        return sample_seconds(self.step, self.n)


def batch_rows(sizes, repeat: int) -> list[list[object]]:
    result = []
    for n in sizes:
        rows, fused = Rows(n), FusedStep("upright", n)
        rows.advance()
        runs = {
            "advance": lambda rows=rows, n=n: sample_seconds(rows.advance, n),
            "lanes": LanesLoop(n),
            "fused": fused,
        }
        seconds = medians_in_turns(runs, repeat)
        fused.env.close()
        advance, lanes, step = seconds["advance"], seconds["lanes"], seconds["fused"]
        result.append(
            [
                n,
                f"{advance / n * 1e9:.0f}",
                f"{n / advance / 1e6:.2f}",
                f"{lanes / n * 1e9:.0f}",
                f"{n / lanes / 1e6:.2f}",
                f"{step / n * 1e9:.0f}",
                f"{lanes / step:.2f}",
            ]
        )
    return result


def fused_rows(n: int, repeat: int) -> list[list[object]]:
    """Per task: the fused step and RK4's lanes loop on n disks, ns a disk, and their ratio (in this process's
    compile target); each repeat times the lanes loop and every task's step in turn, the medians are reported."""
    runs = {"rk4": LanesLoop(n), **{task: FusedStep(task, n) for task in TASKS}}
    seconds = medians_in_turns(runs, repeat)
    lanes = seconds["rk4"] / n * 1e9
    rows = []
    for task in TASKS:
        fused = seconds[task] / n * 1e9
        rows.append([task, f"{fused:.0f}", f"{lanes:.0f}", f"{fused / lanes:.2f}"])
        runs[task].env.close()
    return rows


def ulps(values: np.ndarray, reference: np.ndarray) -> float:
    """The largest difference between ``values`` and ``reference`` in units of the reference's last place."""
    return float(np.max(np.abs(values - reference) / np.spacing(np.abs(reference))))


def sincos_rows(sizes, repeat: int) -> list[list[object]]:
    rows = []
    for n in sizes:
        angles = np.random.default_rng(0).uniform(-4, 4, n)
        number = max(20, 400_000 // n)
        outputs = {}
        seconds = {}
        for name, loop in (("ours", sincos_ours), ("libm", sincos_libm), ("numpy", sincos_numpy)):
            sines, cosines = np.empty(n), np.empty(n)
            loop(angles, sines, cosines)
            outputs[name] = (sines, cosines)
            seconds[name] = median_seconds(
                lambda loop=loop, a=angles, s=sines, c=cosines: loop(a, s, c), number, repeat
            )
        error = max(ulps(outputs["ours"][k], outputs["libm"][k]) for k in range(2))
        rows.append(
            [
                n,
                f"{seconds['ours'] / n * 1e9:.2f}",
                f"{seconds['libm'] / n * 1e9:.2f}",
                f"{seconds['numpy'] / n * 1e9:.2f}",
                f"{seconds['libm'] / seconds['ours']:.2f}",
                f"{error:.0f}",
            ]
        )
    return rows


FUSED_N = 4096
"""Disks of the fused steps' table."""


def main() -> None:
    args = arguments(__doc__, **{"fused-child": {"action": "store_true", "help": "internal: one target's fused steps"}})
    repeat = 3 if args.quick else 7
    if args.fused_child:
        print(json.dumps([fused_rows(FUSED_N, repeat), cpu()]))
        return
    fused = []
    for target in TARGETS:
        rows, target_cpu = in_target(__file__, target, ["--fused-child"] + (["--quick"] if args.quick else []))
        fused += [f"### Compiled for {target}: {target_cpu}", "", table(FUSED_HEADER, rows), ""]
    sizes = (1, 16, 256, 4096) if args.quick else (1, 16, 256, 4096, 65536)
    one = one_disk_rows(repeat)
    batch = batch_rows(sizes, repeat)
    sines = sincos_rows((64, 1024, 4096) if args.quick else (64, 1024, 4096, 65536), repeat)
    evaluations = ", ".join(f"{method} {count}" for method, count in EVALUATIONS_PER_STEP.items())
    write_markdown(
        "dynamics",
        "Step cost of the compiled engine",
        "python benchmarks/bench_dynamics.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            "## One disk, RK4",
            "",
            table(["call", "us per step"], one),
            "",
            "## N disks, RK4, per disk-step",
            "",
            table(
                [
                    "N",
                    "`engine.advance` (rows) ns",
                    "M disk-steps/s",
                    "lanes loop ns",
                    "M disk-steps/s",
                    "vector env's fused step, one thread, ns",
                    "RK4's share of the fused step",
                ],
                batch,
            ),
            "",
            f"Derivative evaluations per step: {evaluations}, dopri5 7 per attempted step.",
            "",
            f"## The fused step of every task against RK4's lanes loop, one thread, N = {FUSED_N}, ns a disk, for each"
            " compile target",
            "",
            *fused,
            "## Sine and cosine of N angles in a compiled loop, ns per angle",
            "",
            table(
                [
                    "N",
                    "`trig.sincos`",
                    "`math.sin` + `math.cos` (libm)",
                    "`np.sin` + `np.cos`",
                    "libm / `trig.sincos`",
                    "largest difference from libm (ulp)",
                ],
                sines,
            ),
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
