"""RollingDisk-v0 for N disks in one numpy batch: the ``vector_entry_point`` of the id."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from rolling_disk_env._generated import batched
from rolling_disk_env.dynamics import FULL_MODEL, LEAN_LIMIT
from rolling_disk_env.envs.config import EnvConfig, action_error
from rolling_disk_env.integrators import STEPS, padded_rows, workspace
from rolling_disk_env.tasks.base import BATCHED_MATH


class RollingDiskVectorEnv(VectorEnv):
    """N independent rolling disks stepped together through the batched equations.

    Same arguments, spaces, rewards and ``info`` keys as :class:`~rolling_disk_env.envs.RollingDiskEnv` (``info``
    values are stacked along the first axis; ``"termination"`` comes with its mask ``"_termination"``), plus:

    Args:
        num_envs: N.
        max_episode_steps: truncation after this many steps (``gymnasium.make_vec`` passes the id's 500); None for
            no truncation.

    Sub-environment i is seeded with ``seed + i`` by ``reset(seed=seed)``, as ``SyncVectorEnv`` does, and draws
    its episodes exactly as a single env with that seed would, so both give the same transitions (to round-off:
    the batched sine of :mod:`rolling_disk_env.trig` and ``math``'s may differ in the last bit). Autoreset follows
    Gymnasium's default ``AutoresetMode.NEXT_STEP``: the step after a sub-environment ends resets it, ignores its
    action and returns its first observation with reward 0. ``reset(options={"state": X})`` takes initial states
    of shape (N, 8). Rendering is not offered: render one disk with the single env.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, max_episode_steps: int | None = None, render_mode: None = None, **kwargs):
        if not (isinstance(num_envs, int) and num_envs >= 1):
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if max_episode_steps is not None and not (isinstance(max_episode_steps, int) and max_episode_steps >= 1):
            raise ValueError(f"max_episode_steps must be an integer >= 1 or None, got {max_episode_steps!r}")
        if render_mode is not None:
            raise ValueError("the vector env does not render; render a single RollingDisk-v0 instead")
        self.config = EnvConfig.from_kwargs(**kwargs)
        self.task = self.config.task
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.render_mode = None
        self.dt = self.config.dt
        self.single_action_space = self.config.action_space
        self.single_observation_space = self.config.observation_space
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self._step = STEPS[self.config.integrator][1]
        self._substep = self.config.dt / self.config.substeps
        self._torque_scale = self.config.torque_scale
        self._obs_low = self.single_observation_space.low[:, None]
        self._obs_high = self.single_observation_space.high[:, None]
        actuators = self.single_action_space.shape[0]
        self._mean_weights = np.full(actuators, 1.0 / actuators) if actuators else np.zeros(0)
        self._rngs = [seeding.np_random()[0] for _ in range(num_envs)]
        self._x = padded_rows(FULL_MODEL.size, num_envs)
        self._x[:] = 0.0
        self._previous = padded_rows(FULL_MODEL.size, num_envs)
        self._work = workspace(self._x.shape)
        self._constants = np.zeros((3, num_envs))
        # Without per-episode randomization every disk has the same constants: floats cost half as much as rows.
        self._shared_constants = None if self.config.params_ranges else self.config.params.constants
        self._goal: dict[str, np.ndarray] = {}
        self._torques = np.zeros((2, num_envs))
        self._elapsed = np.zeros(num_envs, dtype=np.int64)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._error_sums = np.zeros((num_envs, (max_episode_steps or 1024) + 1))
        self._index = np.arange(num_envs)

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None):
        states = self.config.reset_state(options, self.num_envs)
        if seed is not None:
            seeds = [seed + i for i in range(self.num_envs)] if isinstance(seed, int) else list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed must be an int or a list of {self.num_envs} ints, got {seed!r}")
            self._rngs = [seeding.np_random(s)[0] for s in seeds]
        self._start_episodes(self._index, states)
        self._autoreset[:] = False
        self._torques[:] = 0.0
        terms = {}
        return self._observations(), self._infos(terms, np.zeros(self.num_envs, dtype=bool), None)

    def _start_episodes(self, indices: np.ndarray, states: np.ndarray | None = None) -> None:
        """Starts new episodes in the sub-environments ``indices``, each drawn from its own generator with the
        single env's draws and formulas; ``states`` (shape (len(indices), 8)) then sets the states exactly."""
        draws = self.config.draws
        uniforms = np.array([self._rngs[i].random(draws) for i in indices.tolist()]).reshape(len(indices), draws)
        constants, goal, state = self.config.episode(uniforms.T, BATCHED_MATH)
        for row, value in enumerate(state if states is None else states.T):
            self._x[row, indices] = value
        if self._shared_constants is None:
            for row, value in enumerate(constants):
                self._constants[row, indices] = value
        for key, value in goal.items():
            self._goal.setdefault(key, np.zeros(self.num_envs))[indices] = value
        self._elapsed[indices] = 0
        self._error_sums[indices, 0] = 0.0

    def step(self, actions):
        error = action_error(actions, self.action_space.shape)
        if error:
            raise ValueError(error.replace("action", "actions", 1))
        clipped = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
        torques = self._torque_scale @ clipped.T
        effort = (clipped * clipped) @ self._mean_weights
        x = self._x
        np.copyto(self._previous, x)
        args = (torques[0], torques[1], *self._disk_constants())
        with np.errstate(all="ignore"):
            for _ in range(self.config.substeps):
                self._step(FULL_MODEL.batched, x, self._substep, args, self._work)
            in_domain = (np.abs(x[3]) < LEAN_LIMIT) & np.isfinite(x.sum(axis=0))
        if not in_domain.all():
            x[:, ~in_domain] = self._previous[:, ~in_domain]
        self._torques = torques

        resetting = self._autoreset
        if resetting.any():
            self._start_episodes(np.flatnonzero(resetting))
        self._torques[:, resetting] = 0.0
        self._elapsed += ~resetting

        terms = self.task.reward_terms(x, effort, self._goal, BATCHED_MATH)
        rewards = np.where(resetting, 0.0, self.task.reward(terms))
        terminated = (self.task.fallen(x, BATCHED_MATH) | ~in_domain) & ~resetting
        limit = self.max_episode_steps
        truncated = (self._elapsed >= limit) & ~resetting if limit is not None else np.zeros(self.num_envs, bool)
        if self.task.success_bound is not None:
            self._record_tracking_error(resetting)
        infos = self._infos(terms, terminated, in_domain)
        self._autoreset = terminated | truncated
        return self._observations(), rewards, terminated, truncated, infos

    def _disk_constants(self):
        """``(m, g, r)``: floats shared by every disk, or rows of shape (N,) with ``params_ranges``."""
        return self._shared_constants or tuple(self._constants)

    def _record_tracking_error(self, resetting: np.ndarray) -> None:
        if self._elapsed.max() >= self._error_sums.shape[1]:
            self._error_sums = np.concatenate([self._error_sums, np.zeros_like(self._error_sums)], axis=1)
        error = self.task.tracking_error(self._x, self._goal, BATCHED_MATH)
        stepped = self._index[~resetting]
        steps = self._elapsed[stepped]
        self._error_sums[stepped, steps] = self._error_sums[stepped, steps - 1] + error[stepped]

    def _observations(self) -> np.ndarray:
        components = self.task.observe(self._x, self._goal, BATCHED_MATH)
        # Component-major while clipping: numpy's clip against per-column bounds is slow on rows of 4 values.
        observation = np.empty((len(components), self.num_envs), dtype=np.float32)
        for row, component in enumerate(components):
            observation[row] = component
        np.clip(observation, self._obs_low, self._obs_high, out=observation)
        return observation.T.copy()

    def _infos(self, terms: dict, terminated: np.ndarray, in_domain: np.ndarray | None) -> dict:
        x = self._x
        m, g, r = self._disk_constants()
        if self.task.success_bound is None:
            success = ~terminated
        else:
            half = self._elapsed // 2
            totals = self._error_sums[self._index, self._elapsed] - self._error_sums[self._index, half]
            mean_error = totals / np.maximum(1, self._elapsed - half)
            success = ~terminated & (mean_error <= self.task.success_bound)
        diagnostics = batched.diagnostics(x, *self._torques, m, g, r, np.empty((3, self.num_envs)))
        infos = {
            "state": x.T.copy(),
            "energy": diagnostics[0],
            "contact_force": diagnostics[1:].T.copy(),
            # Terms are fresh arrays each step, or constants such as "alive".
            "rewards": {
                name: np.full(self.num_envs, value) if np.ndim(value) == 0 else value for name, value in terms.items()
            },
            "is_success": success,
        }
        if in_domain is not None and terminated.any():
            reasons = np.full(self.num_envs, None, dtype=object)
            reasons[terminated] = "fallen"
            reasons[terminated & ~in_domain] = "out_of_domain"
            infos["termination"] = reasons
            infos["_termination"] = terminated.copy()
        return infos
