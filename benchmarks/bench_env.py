"""Env speed: one ``env.step`` against Gymnasium's classic-control envs, and vector-env throughput against N.

``python benchmarks/bench_env.py [--quick]`` writes ``benchmarks/results/env_speed.md`` and ``env_throughput.png``.
Every env is built with ``gymnasium.make`` and its defaults (so with its wrappers), stepped with pre-drawn random
actions and reset when an episode ends; the envs are timed in turn within each repeat, so a slow spell of the shared
machine hits all of them, and the table reports medians and ratios taken within the run.
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
from _common import RESULTS, table, write_markdown

import rolling_disk_env as rd

SINGLE = {
    "RollingDisk-v0 (upright)": (rd.ENV_ID, {}),
    "RollingDisk-v0 (circle)": (rd.ENV_ID, {"task": "circle"}),
    "CartPole-v1": ("CartPole-v1", {}),
    "Pendulum-v1": ("Pendulum-v1", {}),
    "Acrobot-v1": ("Acrobot-v1", {}),
}


def _stepper(env_id: str, kwargs: dict, steps: int):
    env = gym.make(env_id, **kwargs)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    env.reset(seed=0)

    def run() -> float:
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        return (time.perf_counter() - start) / steps

    run()
    return run


def single_env_times(steps: int, repeats: int) -> dict[str, float]:
    runs = {name: _stepper(env_id, kwargs, steps) for name, (env_id, kwargs) in SINGLE.items()}
    samples = {name: [] for name in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            samples[name].append(run())
    return {name: statistics.median(values) for name, values in samples.items()}


def vector_throughput(env_id: str, sizes, steps: int, repeats: int) -> list[float]:
    rates = []
    for n in sizes:
        env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
        env.action_space.seed(0)
        env.reset(seed=0)
        count = min(max(20, steps // n), 2000)
        actions = [env.action_space.sample() for _ in range(count)]
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            for action in actions:
                env.step(action)
            samples.append(n * count / (time.perf_counter() - start))
        rates.append(statistics.median(samples))
        env.close()
    return rates


def chart(sizes, ours, cartpole, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.loglog(sizes, ours, "o-", label="RollingDisk-v0 (RK4, 8-state exact model)")
    ax.loglog(sizes, cartpole, "s--", label="CartPole-v1 native vector env (Euler, 4 states)")
    ax.axhline(3e6, color="gray", lw=0.8, ls=":", label="3M steps/s")
    ax.set_xlabel("number of environments N")
    ax.set_ylabel("env steps per second")
    ax.set_title("Native vector env throughput (median)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps and repeats (a smoke run)")
    args = parser.parse_args()
    steps, repeats = (2_000, 3) if args.quick else (20_000, 7)
    sizes = [1, 4, 16, 64, 256, 1024, 4096, 16384]

    times = single_env_times(steps, repeats)
    acrobot, cartpole = times["Acrobot-v1"], times["CartPole-v1"]
    single_rows = [
        [name, f"{seconds * 1e6:.2f}", f"{seconds / acrobot:.2f}", f"{seconds / cartpole:.2f}"]
        for name, seconds in times.items()
    ]
    vector_steps = 100_000 if args.quick else 1_000_000
    ours = vector_throughput(rd.ENV_ID, sizes, vector_steps, repeats)
    theirs = vector_throughput("CartPole-v1", sizes, vector_steps, repeats)
    chart(sizes, ours, theirs, RESULTS / "env_throughput.png")
    vector_rows = [[n, f"{a / 1e6:.3f}", f"{b / 1e6:.3f}", f"{a / b:.2f}"] for n, a, b in zip(sizes, ours, theirs)]
    write_markdown(
        "env_speed",
        "Env speed",
        "python benchmarks/bench_env.py",
        [
            f"## One `env.step` through `gymnasium.make` (median of {repeats} runs of {steps} steps, random actions)",
            "",
            table(["env", "us / step", "ratio to Acrobot-v1", "ratio to CartPole-v1"], single_rows),
            "",
            '## Native vector env (`make_vec(..., vectorization_mode="vector_entry_point")`), random actions',
            "",
            table(["N", "RollingDisk-v0 M steps/s", "CartPole-v1 M steps/s", "ratio"], vector_rows),
            "",
            "![throughput](env_throughput.png)",
        ],
    )


if __name__ == "__main__":
    main()
