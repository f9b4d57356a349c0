"""Threads under a busy core: the default vector env against the same env on one thread, idle and while another
process keeps a core busy.

``python benchmarks/bench_threads.py [--quick] [--out DIR]`` writes ``threads.md`` to DIR (default
``benchmarks/results``).

Each sample is a fresh process stepping ``gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")``
with random actions (Gymnasium's next-step autoreset) for about a second after a warm-up, as a user's process would:
the env as it comes (from ``envs.batch.THREADS_FROM`` disks one share per numba thread, stepped on the threads or not
as its recent steps measured faster: ``envs.batch.ThreadChoice``) against the same env with ``NUMBA_NUM_THREADS=1``.
The two run in interleaved pairs (the order alternating), so a slow spell of the shared machine hits both; the table
gives the median steps per second and the median of the pairs' ratios. Busy: a Python process spinning in a loop
from before the pair to after it, as torch training or a second job beside the env would.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time

from _common import arguments, table, write_markdown

N = 4096
TASKS = ("upright", "circle", "goto")
CHILD = """
import json, sys, time
import gymnasium as gym, numpy as np
import rolling_disk_env as rd
env = gym.make_vec(rd.ENV_ID, num_envs={n}, vectorization_mode="vector_entry_point", task="{task}")
env.reset(seed=0)
actions = np.random.default_rng(0).uniform(-1, 1, (64, {n}, 2)).astype(np.float32)
for step in range(100):
    env.step(actions[step % 64])
start, steps = time.perf_counter(), 0
while time.perf_counter() - start < {seconds}:
    env.step(actions[steps % 64])
    steps += 1
choice = env.unwrapped._batch.choice
print(json.dumps({{"rate": {n} * steps / (time.perf_counter() - start),
                  "threads": None if choice is None else choice.threaded}}))
"""
"""A sample: steps per second of the env after a warm-up, and whether it was stepping on its threads at the end."""


def sample(task: str, one_thread: bool, seconds: float) -> dict:
    environment = {**os.environ, **({"NUMBA_NUM_THREADS": "1"} if one_thread else {})}
    code = CHILD.format(n=N, task=task, seconds=seconds)
    result = subprocess.run([sys.executable, "-c", code], env=environment, capture_output=True, text=True, check=True)
    return json.loads(result.stdout.splitlines()[-1])


def pairs(task: str, busy: bool, count: int, seconds: float) -> list[tuple[dict, dict]]:
    """``count`` pairs of samples (default env, one thread), with a spinning process beside them if ``busy``."""
    result = []
    for i in range(count):
        spinner = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if busy else None
        try:
            time.sleep(0.2 if busy else 0.0)
            first, second = sample(task, i % 2 == 1, seconds), sample(task, i % 2 == 0, seconds)
        finally:
            if spinner is not None:
                spinner.kill()
                spinner.wait()
        result.append((second, first) if i % 2 else (first, second))
    return result


def main() -> None:
    args = arguments(__doc__)
    count, seconds = (2, 0.3) if args.quick else (15, 1.0)
    sample("upright", False, 0.1)  # compiles what is not in the cache yet
    rows = []
    for busy in (False, True):
        for task in TASKS:
            measured = pairs(task, busy, count, seconds)
            default = [pair[0]["rate"] for pair in measured]
            single = [pair[1]["rate"] for pair in measured]
            ratios = [pair[0]["rate"] / pair[1]["rate"] for pair in measured]
            on_threads = sum(bool(pair[0]["threads"]) for pair in measured)
            rows.append(
                [
                    "one core busy" if busy else "idle",
                    task,
                    f"{statistics.median(default) / 1e6:.2f}",
                    f"{statistics.median(single) / 1e6:.2f}",
                    f"{statistics.median(ratios):.2f}",
                    f"{min(ratios):.2f} to {max(ratios):.2f}",
                    f"{on_threads} of {count}",
                ]
            )
    write_markdown(
        "threads",
        "Threads under a busy core",
        "python benchmarks/bench_threads.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            f"## N = {N}, {count} pairs of samples of about {seconds:g} s",
            "",
            table(
                [
                    "cores",
                    "task",
                    "default M steps/s",
                    "NUMBA_NUM_THREADS=1 M steps/s",
                    "default / one thread (median of pairs)",
                    "range of the pairs",
                    "default on its threads at the end",
                ],
                rows,
            ),
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
