"""A planner on the exact model: model-predictive control by the cross-entropy method (CEM), the engine as its model.

At every control period, for every episode under way, :class:`CEMPlanner` copies the disk's exact state (the
engine's lanes, its goal and progress) into ``samples`` disks of a vector env of its own, steps them through
``horizon`` periods under action sequences drawn from a Gaussian, scores each by the task's own reward summed over
the horizon (nothing after a termination), refits the Gaussian to the best ``elites`` and does it again
(``iterations``), then plays the first action of the mean; the rest of the plan, shifted, starts the next period's
search. It shows what the task's dynamics and action bounds allow, from the state: where it succeeds, a policy
that learns from the observation could too, for the tasks whose observation holds the disk's whole state but for
its place and heading (``recovery``, ``ice``: their task modules say so).

It runs every episode of an evaluation at once, ``episodes x samples`` disks in one batch (:func:`evaluate_planner`).
"""

from __future__ import annotations

import numpy as np

import rolling_disk_env as rd
from agents.evaluate import EVAL_SEED, Result


class CEMPlanner:
    """Model-predictive control by the cross-entropy method, on the env's own engine.

    Args:
        horizon: control periods of a plan.
        samples: action sequences tried per episode and iteration.
        elites: the best sequences the Gaussian is refitted to.
        iterations: refits per control period.
        spread: the standard deviation of a period's first search around the plan before it (actions in [-1, 1]).
        seed: seeds the planner's draws.
        **env_kwargs: the env's keyword arguments (``task`` and the others), those of the episodes it plans for.
    """

    def __init__(self, horizon=50, samples=128, elites=12, iterations=4, spread=0.5, seed=0, **env_kwargs):
        self.horizon, self.samples, self.elites, self.iterations = horizon, samples, elites, iterations
        self.spread, self.env_kwargs = spread, env_kwargs
        self.rng = np.random.default_rng(seed)
        self.rollouts: rd.RollingDiskVectorEnv | None = None
        self.plans: np.ndarray | None = None  # (episodes, horizon, actions): each episode's plan

    def start(self, episodes: int, actions: int) -> None:
        """Readies the rollouts' batch for ``episodes`` episodes under way and empties the plans."""
        total = episodes * self.samples
        if self.rollouts is None or self.rollouts.num_envs != total:
            self.rollouts = rd.RollingDiskVectorEnv(num_envs=total, **self.env_kwargs)
            self.rollouts.reset(seed=0)
        self.plans = np.zeros((episodes, self.horizon, actions), dtype=np.float32)

    def act(self, source: rd.RollingDiskVectorEnv) -> np.ndarray:
        """The actions of the episodes of ``source`` (a vector env of the same configuration, one episode a
        sub-environment) for its next step: (episodes, actions) float32."""
        episodes, horizon, size = self.plans.shape
        samples, elites = self.samples, self.elites
        mean = np.concatenate([self.plans[:, 1:], self.plans[:, -1:]], axis=1)
        spread = np.full_like(mean, self.spread)
        for _ in range(self.iterations):
            noise = self.rng.standard_normal((episodes, samples, horizon, size)).astype(np.float32)
            tries = np.clip(mean[:, None] + spread[:, None] * noise, -1.0, 1.0)
            tries[:, 0] = mean  # the plan itself is always tried
            scores = self._scores(source, tries.reshape(episodes * samples, horizon, size)).reshape(episodes, samples)
            best = np.argsort(-scores, axis=1)[:, :elites]
            chosen = np.take_along_axis(tries, best[:, :, None, None], axis=1)
            mean, spread = chosen.mean(axis=1), chosen.std(axis=1) + 0.05
        self.plans = mean
        return mean[:, 0].copy()

    def _scores(self, source: rd.RollingDiskVectorEnv, tries: np.ndarray) -> np.ndarray:
        """The reward of each action sequence of ``tries`` (episodes x samples, horizon, actions) summed over the
        horizon from its episode's state in ``source``, nothing after a termination."""
        rollouts, samples = self.rollouts, self.samples
        batch, copy = rollouts._batch, source._batch
        count = source.num_envs
        columns = np.repeat(np.arange(count), samples)
        batch.lanes[:, : rollouts.num_envs] = copy.lanes[:, columns]
        batch.goals[:, : rollouts.num_envs] = copy.goals[:, columns]
        batch.steps[: rollouts.num_envs] = copy.steps[columns]
        rollouts._ended[:] = False
        scores = np.zeros(rollouts.num_envs)
        running = np.ones(rollouts.num_envs, dtype=bool)
        for step in range(tries.shape[1]):
            _, rewards, terminated, truncated, _ = rollouts.step(np.ascontiguousarray(tries[:, step]))
            scores += np.where(running, rewards, 0.0)
            running &= ~(terminated | truncated)
        return scores


def evaluate_planner(planner: CEMPlanner, name: str, episodes: int = 100, seed: int = EVAL_SEED) -> Result:
    """:func:`agents.evaluate.evaluate` for a planner: the same seeded episodes at once on the native vector env,
    the planner reading their exact states."""
    task = planner.env_kwargs.get("task", "upright")
    env = rd.RollingDiskVectorEnv(num_envs=episodes, max_episode_steps=rd.TASK_MAX_STEPS[task], **planner.env_kwargs)
    env.reset(seed=seed)
    planner.start(episodes, env.single_action_space.shape[0])
    returns = np.zeros(episodes)
    successes = np.zeros(episodes, dtype=bool)
    finished = np.zeros(episodes, dtype=bool)
    while not finished.all():
        _, rewards, terminated, truncated, infos = env.step(planner.act(env))
        returns += np.where(finished, 0.0, rewards)
        ending = (terminated | truncated) & ~finished
        successes |= ending & infos["is_success"]
        finished |= ending
    return Result(name, returns, successes)
