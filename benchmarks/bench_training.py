"""Training speed: PPO on the main job's settings with SB3's ``DummyVecEnv`` against the SB3 VecEnv over the native
vector env.

``python benchmarks/bench_training.py [--quick] [--out DIR] [--timesteps N]`` writes ``training_speed.md`` to DIR
(default ``benchmarks/results``).

The main job's settings: the ``RollingDiskUpright-v0`` block of ``agents/hyperparams/ppo.yml`` read as
``agents.training`` reads it (its envs, VecNormalize, PPO's hyperparameters and network), one torch thread, seed 0.
Two VecEnvs give PPO the same disks with the same seeds: SB3's ``make_vec_env(..., vec_env_cls=DummyVecEnv)``
over single envs (what ``train.py`` uses), and ``rolling_disk_env.sb3.make_vec_env`` (``VecMonitor`` over
``NativeVecEnv``: one compiled call steps the disks).

1. One step of the envs with random actions, each VecEnv and the native vector env alone (no adapter), medians
   of 5 runs of 2,000 steps timed in turn.
2. ``PPO.learn`` for ``--timesteps`` steps (default 50,000; 4,096 with ``--quick``) without evaluations, a fresh
   model and VecEnv per run, the two VecEnvs in turn after an untimed rollout with each, medians of 3 runs (1 with
   ``--quick``); and whether the two trained the same parameters to the last bit (the adapter gives
   ``DummyVecEnv``'s observations, rewards and dones, so they should).
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import torch
from _common import arguments, medians_in_turns, table, write_markdown
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

import rolling_disk_env as rd
from agents.training import HYPERPARAMS, algorithm_kwargs, load_hyperparams, normalize_kwargs
from rolling_disk_env import sb3

TASK = "upright"
ENV_ID = rd.TASK_IDS[TASK]
SEED = 0


def dummy(n_envs: int):
    return make_vec_env(ENV_ID, n_envs=n_envs, seed=SEED, vec_env_cls=DummyVecEnv)


def native(n_envs: int):
    return sb3.make_vec_env(ENV_ID, n_envs=n_envs, seed=SEED)


VEC_ENVS = {"DummyVecEnv (SB3, single envs)": dummy, "`rolling_disk_env.sb3.make_vec_env` (native)": native}


def stepping_rows(n_envs: int, repeats: int) -> list[list[object]]:
    actions = np.random.default_rng(0).uniform(-1, 1, (2000, n_envs, 2)).astype(np.float32)
    envs = {name: make(n_envs) for name, make in VEC_ENVS.items()}
    bare = rd.RollingDiskVectorEnv(num_envs=n_envs, max_episode_steps=rd.MAX_EPISODE_STEPS)
    bare.reset(seed=SEED)
    for env in envs.values():
        env.reset()

    def timer(step):
        def run() -> float:
            start = time.perf_counter()
            for action in actions:
                step(action)
            return (time.perf_counter() - start) / len(actions)

        run()
        return run

    runs = {name: timer(env.step) for name, env in envs.items()}
    runs["native vector env alone (no adapter)"] = timer(bare.step)
    seconds = medians_in_turns(runs, repeats)
    for env in (*envs.values(), bare):
        env.close()
    reference = seconds[next(iter(VEC_ENVS))]
    return [[name, f"{value * 1e6:.0f}", f"{value / reference:.2f}"] for name, value in seconds.items()]


def learn(make, block: dict, timesteps: int) -> tuple[float, list[torch.Tensor]]:
    """(wall seconds of ``PPO.learn``, the trained parameters) on a fresh VecEnv from ``make``."""
    env = make(int(block.get("n_envs", 1)))
    normalization = normalize_kwargs(block)
    if normalization is not None:
        env = VecNormalize(env, **normalization)
    model = PPO(
        block.get("policy", "MlpPolicy"), env, seed=SEED, device="cpu", verbose=0, **algorithm_kwargs("ppo", block)
    )
    start = time.perf_counter()
    model.learn(total_timesteps=timesteps)
    seconds = time.perf_counter() - start
    env.close()
    return seconds, [parameter.detach().clone() for parameter in model.policy.parameters()]


def main() -> None:
    args = arguments(__doc__, timesteps=dict(type=int, default=None, help="PPO steps per run (default 50,000)"))
    timesteps = args.timesteps or (4_096 if args.quick else 50_000)
    repeats = 1 if args.quick else 3
    torch.set_num_threads(1)
    block = load_hyperparams(HYPERPARAMS / "ppo.yml", ENV_ID)
    n_envs = int(block.get("n_envs", 1))
    stepping = stepping_rows(n_envs, 5)
    for make in VEC_ENVS.values():  # torch's and the engine's first-call costs, outside the timed runs
        learn(make, block, 1)
    samples = {name: [] for name in VEC_ENVS}
    parameters = {}
    for _ in range(repeats):
        for name, make in VEC_ENVS.items():
            seconds, parameters[name] = learn(make, block, timesteps)
            samples[name].append(seconds)
    medians = {name: statistics.median(values) for name, values in samples.items()}
    reference = medians[next(iter(VEC_ENVS))]
    ppo_rows = [
        [name, f"{value:.1f}", f"{timesteps / value:.0f}", f"{value / reference:.2f}"]
        for name, value in medians.items()
    ]
    first, second = parameters.values()
    same = all(torch.equal(a, b) for a, b in zip(first, second))
    write_markdown(
        "training_speed",
        "Training speed: PPO with DummyVecEnv and with the native vector env",
        "python benchmarks/bench_training.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            f"## (1) One step of {n_envs} environments, random actions",
            "",
            table(["VecEnv", f"us per step of all {n_envs}", "ratio to DummyVecEnv"], stepping),
            "",
            f"## (2) PPO, {timesteps:,} steps, {TASK}, 1 torch thread",
            "",
            table(["VecEnv", "wall time (s)", "steps / s", "ratio to DummyVecEnv"], ppo_rows),
            "",
            "Same trained parameters with both VecEnvs, to the last bit: " + ("yes." if same else "no."),
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
