"""What makes PPO fastest here: the VecEnv and torch's thread count.

``python benchmarks/bench_training.py`` writes ``benchmarks/results/training_speed.md``. (1) Stepping alone, 8
environments with random actions: SB3's DummyVecEnv and SubprocVecEnv over single envs, and the native batched
``RollingDiskVectorEnv`` at N = 8, the floor under any SB3 adapter around it (an adapter only adds conversions).
(2) PPO wall time for 50,000 steps on ``upright`` with the default hyperparameters, per VecEnv and thread count.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import torch
from _common import table, write_markdown
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

import rolling_disk_env as rd

N_ENVS = 8
ENV_ID = f"rolling_disk_env:{rd.ENV_ID}"


def stepping_seconds(step, actions, repeats=5) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for action in actions:
            step(action)
        samples.append((time.perf_counter() - start) / len(actions))
    return statistics.median(samples)


def main() -> None:
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (2000, N_ENVS, 2)).astype(np.float32)
    rows = []
    for name, cls in (("DummyVecEnv", DummyVecEnv), ("SubprocVecEnv", SubprocVecEnv)):
        vec = make_vec_env(ENV_ID, n_envs=N_ENVS, seed=0, vec_env_cls=cls)
        vec.reset()
        rows.append([name, f"{stepping_seconds(vec.step, actions) * 1e6:.0f}"])
        vec.close()
    native = rd.RollingDiskVectorEnv(num_envs=N_ENVS, max_episode_steps=rd.MAX_EPISODE_STEPS)
    native.reset(seed=0)
    rows.append(["RollingDiskVectorEnv (native, no adapter)", f"{stepping_seconds(native.step, actions) * 1e6:.0f}"])

    ppo_rows = []
    for name, cls, threads in (
        ("DummyVecEnv", DummyVecEnv, 1),
        ("DummyVecEnv", DummyVecEnv, 2),
        ("SubprocVecEnv", SubprocVecEnv, 1),
    ):
        torch.set_num_threads(threads)
        vec = make_vec_env(ENV_ID, n_envs=N_ENVS, seed=0, vec_env_cls=cls)
        model = PPO("MlpPolicy", vec, n_steps=256, batch_size=256, seed=0, device="cpu", verbose=0)
        start = time.perf_counter()
        model.learn(50_000)
        seconds = time.perf_counter() - start
        ppo_rows.append([name, threads, f"{seconds:.1f}", f"{50_000 / seconds:.0f}"])
        vec.close()
    write_markdown(
        "training_speed",
        "Training speed: VecEnv and threads for PPO",
        "python benchmarks/bench_training.py",
        [
            __doc__.split("\n\n", 1)[1].strip(),
            "",
            f"## (1) One step of {N_ENVS} environments (median of 5 x 2000)",
            "",
            table(["VecEnv", "us per step of all 8"], rows),
            "",
            "## (2) PPO, 50,000 steps, upright",
            "",
            table(["VecEnv", "torch threads", "wall time (s)", "steps / s"], ppo_rows),
        ],
    )


if __name__ == "__main__":
    main()
