"""Evaluate agents on RollingDisk-v0: a table of return and success, a video of one episode, and plots.

``python -m agents.evaluate --task upright --model runs/upright_ppo_0/best_model.zip`` (or ``--agent lqr`` or
``--agent passive``) runs seeded episodes on the native vector env, prints mean +- std return and success rate, and
with ``--out DIR`` writes ``episode.gif`` (the env's renderer) and ``episode.png`` (lean, spin rate, torques and
the track seen from above against the target).
"""

from __future__ import annotations

import pickle
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import rolling_disk_env as rd

EVAL_SEED = 10_000
"""Evaluation episodes use seeds from here on: training uses others."""


@dataclass(frozen=True)
class Result:
    """Return and success over evaluation episodes."""

    name: str
    returns: np.ndarray
    successes: np.ndarray

    def row(self) -> list[str]:
        return [
            self.name,
            f"{self.returns.mean():.1f} +- {self.returns.std():.1f}",
            f"{100 * self.successes.mean():.0f}%",
        ]


class PassiveAgent:
    """Zero torque: the disk rolls on its own."""

    def __init__(self, action_size: int = 2):
        self.action_size = action_size

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        observation = np.asarray(observation)
        return np.zeros((*observation.shape[:-1], self.action_size), dtype=np.float32), None


class NormalizedPolicy:
    """A trained SB3 model with the VecNormalize observation statistics it was trained with."""

    def __init__(self, model, normalize=None):
        self.model, self.normalize = model, normalize

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if self.normalize is not None:
            observation = self.normalize.normalize_obs(np.asarray(observation, dtype=np.float32))
        return self.model.predict(observation, deterministic=deterministic)


def load_agent(path: Path):
    """A saved model (``.zip``) with ``vecnormalize.pkl`` from its folder, if there is one."""
    from stable_baselines3 import PPO, SAC, TD3
    from stable_baselines3.common.vec_env import VecNormalize

    algorithms = {"ppo": PPO, "sac": SAC, "td3": TD3}
    run = path.parent
    algo = (run / "algo.txt").read_text().strip() if (run / "algo.txt").exists() else "ppo"
    model = algorithms[algo].load(path, device="cpu")
    normalize = None
    stats = run / "vecnormalize.pkl"
    if stats.exists():
        # VecNormalize.save pickles the statistics without the training envs; normalize_obs needs only those.
        with open(stats, "rb") as handle:
            normalize = pickle.load(handle)
        if not isinstance(normalize, VecNormalize):
            raise ValueError(f"{stats} does not hold VecNormalize statistics")
        normalize.training = False
    return NormalizedPolicy(model, normalize)


def evaluate(agent, name: str, episodes: int = 100, seed: int = EVAL_SEED, **env_kwargs) -> Result:
    """Runs ``episodes`` seeded episodes at once on the native vector env, one episode per sub-environment."""
    env = rd.RollingDiskVectorEnv(num_envs=episodes, max_episode_steps=rd.MAX_EPISODE_STEPS, **env_kwargs)
    observations, _ = env.reset(seed=seed)
    returns = np.zeros(episodes)
    successes = np.zeros(episodes, dtype=bool)
    finished = np.zeros(episodes, dtype=bool)
    while not finished.all():
        actions, _ = agent.predict(observations, deterministic=True)
        observations, rewards, terminated, truncated, infos = env.step(actions)
        returns += np.where(finished, 0.0, rewards)
        ending = (terminated | truncated) & ~finished
        successes |= ending & infos["is_success"]
        finished |= ending
    return Result(name, returns, successes)
