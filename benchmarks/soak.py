"""Soak: 10^6 steps of random actions across resets, in the single and the vector env (10^7 at N = 4096).

``python benchmarks/soak.py [--steps N]`` writes ``benchmarks/results/soak.md``: whether any observation, reward or
state was non-finite, and the resident memory at the start, middle and end of each run (flat memory: no growth).
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np
from _common import table, write_markdown

import rolling_disk_env as rd


def resident_mib() -> float:
    with open("/proc/self/statm") as statm:
        pages = int(statm.read().split()[1])
    return pages * 4096 / 2**20


def soak_single(task: str, steps: int) -> list[object]:
    env = gym.make(rd.ENV_ID, task=task)
    env.action_space.seed(0)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    episodes, bad, memory = 0, 0, [resident_mib()]
    start = time.perf_counter()
    for i in range(steps):
        action = rng.uniform(-1.5, 1.5, 2).astype(np.float32)
        observation, reward, terminated, truncated, info = env.step(action)
        if not (np.all(np.isfinite(observation)) and np.isfinite(reward) and np.all(np.isfinite(info["state"]))):
            bad += 1
        if terminated or truncated:
            episodes += 1
            env.reset()
        if i == steps // 2:
            memory.append(resident_mib())
    memory.append(resident_mib())
    elapsed = time.perf_counter() - start
    return [f"single, {task}", steps, episodes, bad, *(f"{m:.1f}" for m in memory), f"{elapsed:.0f}"]


def soak_vector(task: str, steps: int, num_envs: int = 64) -> list[object]:
    env = gym.make_vec(rd.ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point", task=task)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    episodes, bad, memory = 0, 0, [resident_mib()]
    start = time.perf_counter()
    calls = steps // num_envs
    for i in range(calls):
        actions = rng.uniform(-1.5, 1.5, (num_envs, 2)).astype(np.float32)
        observations, rewards, terminated, truncated, infos = env.step(actions)
        finite = np.isfinite(observations).all(axis=1) & np.isfinite(rewards) & np.isfinite(infos["state"]).all(axis=1)
        bad += int(np.sum(~finite))
        episodes += int(np.sum(terminated | truncated))
        if i == calls // 2:
            memory.append(resident_mib())
    memory.append(resident_mib())
    elapsed = time.perf_counter() - start
    return [
        f"vector (N = {num_envs}), {task}",
        calls * num_envs,
        episodes,
        bad,
        *(f"{m:.1f}" for m in memory),
        f"{elapsed:.0f}",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1_000_000)
    args = parser.parse_args()
    tasks = ("upright", "circle")
    rows = [soak(task, args.steps) for soak in (soak_single, soak_vector) for task in tasks]
    # Large batches take the torch path for sine and cosine (rolling_disk_env.trig): 10x the steps, 2441 calls.
    rows += [soak_vector(task, 10 * args.steps, num_envs=4096) for task in tasks]
    write_markdown(
        "soak",
        "Soak: random actions (uniform in [-1.5, 1.5], so clipping is exercised) across resets",
        "python benchmarks/soak.py",
        [
            table(
                ["env", "steps", "episodes", "non-finite steps", "RSS start (MiB)", "RSS middle", "RSS end", "s"],
                rows,
            )
        ],
    )


if __name__ == "__main__":
    main()
