"""Soak: random actions across resets in the single env and the vector env, both tasks, watching for non-finite
values and memory growth.

``python benchmarks/soak.py [--quick] [--out DIR] [--steps N]`` writes ``soak.md`` to DIR (default
``benchmarks/results``).

Env steps of random actions, uniform in [-1.5, 1.5] so that clipping is exercised, across as many episodes as they
make (the single env resets when an episode ends; the vector envs reset themselves, Gymnasium's next-step autoreset):
``--steps`` (default 10^6; 2 x 10^4 with ``--quick``) in the single env (``gym.make``) and in the vector env at
N = 64 (``gym.make_vec``, ``vectorization_mode="vector_entry_point"``), 10 times as many at N = 4096 (the parallel
loop). Reported: the steps whose observation, reward or state (``info["state"]``) was not finite, the episodes and
how they terminated (``info["termination"]``; the rest were truncated), and the resident memory after the first step
(which compiles or loads the env's kernels), in the middle and at the end of each run (flat memory: no growth).
"""

from __future__ import annotations

import time
from collections import Counter

import gymnasium as gym
import numpy as np
from _common import arguments, table, write_markdown

import rolling_disk_env as rd

TASKS = ("upright", "circle")


def resident_mib() -> float:
    with open("/proc/self/statm") as statm:
        pages = int(statm.read().split()[1])
    return pages * 4096 / 2**20


def soak_single(task: str, steps: int) -> list[object]:
    env = gym.make(rd.ENV_ID, task=task)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    episodes, bad, reasons, memory = 0, 0, Counter(), []
    start = time.perf_counter()
    for i in range(steps):
        action = rng.uniform(-1.5, 1.5, 2).astype(np.float32)
        observation, reward, terminated, truncated, info = env.step(action)
        if not (np.all(np.isfinite(observation)) and np.isfinite(reward) and np.all(np.isfinite(info["state"]))):
            bad += 1
        if terminated:
            reasons[rd.Termination(info["termination"]).name.lower()] += 1
        if terminated or truncated:
            episodes += 1
            env.reset()
        if i in (0, steps // 2):
            memory.append(resident_mib())
    memory.append(resident_mib())
    return row(f"single, {task}", steps, episodes, bad, reasons, memory, time.perf_counter() - start)


def soak_vector(task: str, steps: int, num_envs: int) -> list[object]:
    env = gym.make_vec(rd.ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point", task=task)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    episodes, bad, reasons, memory = 0, 0, Counter(), []
    start = time.perf_counter()
    calls = max(2, steps // num_envs)
    for i in range(calls):
        actions = rng.uniform(-1.5, 1.5, (num_envs, 2)).astype(np.float32)
        observations, rewards, terminated, truncated, infos = env.step(actions)
        finite = np.isfinite(observations).all(axis=1) & np.isfinite(rewards) & np.isfinite(infos["state"]).all(axis=1)
        bad += int(np.sum(~finite))
        episodes += int(np.sum(terminated | truncated))
        reasons.update(rd.Termination(code).name.lower() for code in infos["termination"][terminated].tolist())
        if i in (0, calls // 2):
            memory.append(resident_mib())
    memory.append(resident_mib())
    env.close()
    elapsed = time.perf_counter() - start
    return row(f"vector (N = {num_envs}), {task}", calls * num_envs, episodes, bad, reasons, memory, elapsed)


def row(name: str, steps: int, episodes: int, bad: int, reasons: Counter, memory, seconds: float) -> list[object]:
    terminations = ", ".join(f"{reason} {count}" for reason, count in sorted(reasons.items())) or "none"
    return [name, steps, episodes, terminations, bad, *(f"{m:.1f}" for m in memory), f"{seconds:.0f}"]


def main() -> None:
    args = arguments(__doc__, steps=dict(type=int, default=None, help="env steps per run (default 10^6)"))
    steps = args.steps or (20_000 if args.quick else 1_000_000)
    rows = [soak_single(task, steps) for task in TASKS]
    rows += [soak_vector(task, steps, num_envs=64) for task in TASKS]
    rows += [soak_vector(task, 10 * steps, num_envs=4096) for task in TASKS]
    write_markdown(
        "soak",
        "Soak: random actions across resets",
        "python benchmarks/soak.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            table(
                [
                    "env",
                    "steps",
                    "episodes",
                    "terminations",
                    "non-finite steps",
                    "RSS after the first step (MiB)",
                    "RSS middle",
                    "RSS end",
                    "s",
                ],
                rows,
            ),
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
