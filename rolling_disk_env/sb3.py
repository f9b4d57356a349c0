"""Stable-Baselines3 on the native vector env: an SB3 ``VecEnv`` that steps all its disks in one compiled call.

``make_vec_env(env_id, n_envs, seed, env_kwargs)`` is the drop-in for SB3's ``make_vec_env`` (it wraps the result in
``VecMonitor``, as ``make_vec_env`` wraps each env in ``Monitor``): the same seeds give the same observations,
rewards, dones and infos as ``DummyVecEnv`` over single envs (``tests/test_sb3.py``). Importing this module imports
Stable-Baselines3 (and with it torch).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers.vector import DictInfoToList

try:
    from stable_baselines3.common.vec_env import VecEnv, VecMonitor
except ImportError as error:
    raise ImportError(
        f'rolling_disk_env.sb3 needs Stable-Baselines3 and torch: pip install "rolling-disk-env[train]" ({error})'
    ) from error

from rolling_disk_env.envs import RollingDiskVectorEnv


class NativeVecEnv(VecEnv):
    """SB3's ``VecEnv`` API over a :class:`~rolling_disk_env.envs.RollingDiskVectorEnv` in ``SAME_STEP`` mode.

    SB3's semantics, as ``DummyVecEnv`` gives them: an episode that ends is reset in the same step, its last
    observation in ``info["terminal_observation"]``, ``info["TimeLimit.truncated"]`` set when it was truncated and
    not terminated, the new episode's reset info in ``reset_infos``; rewards are float32; ``seed(s)`` seeds
    sub-environment i with ``s + i`` at the next ``reset()``.

    Args:
        env: a native vector env created with ``autoreset_mode=AutoresetMode.SAME_STEP``.
    """

    def __init__(self, env: RollingDiskVectorEnv):
        if env.autoreset_mode != AutoresetMode.SAME_STEP:
            raise ValueError(f"NativeVecEnv needs autoreset_mode=SAME_STEP, got {env.autoreset_mode}")
        self.native = env
        self._env = DictInfoToList(env)
        self._actions: np.ndarray | None = None
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)

    def reset(self) -> np.ndarray:
        seeds = None if all(seed is None for seed in self._seeds) else list(self._seeds)
        options = self._options[0] if all(options == self._options[0] for options in self._options) else None
        if options is None:
            raise ValueError("NativeVecEnv takes the same reset options for every sub-environment")
        observations, self.reset_infos = self._env.reset(seed=seeds, options=options or None)
        self._reset_seeds()
        self._reset_options()
        return observations

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        observations, rewards, terminated, truncated, infos = self._env.step(self._actions)
        dones = terminated | truncated
        for i in np.flatnonzero(dones).tolist():
            info = infos[i]
            final_observation, final_info = info.pop("final_obs"), info.pop("final_info")
            self.reset_infos[i] = info
            infos[i] = {**final_info, "terminal_observation": final_observation}
        for info, limited in zip(infos, (truncated & ~terminated).tolist()):
            info["TimeLimit.truncated"] = limited
        return observations, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.native.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        """The attribute of the native env (every sub-environment shares it)."""
        return [getattr(self.native, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        raise AttributeError(f"NativeVecEnv cannot set {attr_name!r} per sub-environment: make a new env instead")

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        raise AttributeError(f"NativeVecEnv cannot call {method_name!r} per sub-environment")

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        return [False] * len(self._get_indices(indices))

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs


def make_vec_env(env_id: str, n_envs: int = 1, seed: int | None = None, env_kwargs: dict | None = None) -> VecMonitor:
    """SB3's ``make_vec_env`` for a RollingDisk id, on the native vector env: ``VecMonitor(NativeVecEnv(...))``."""
    env = gym.make_vec(
        env_id,
        num_envs=n_envs,
        vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP,
        **(env_kwargs or {}),
    )
    vec_env = NativeVecEnv(env)
    vec_env.seed(seed)
    return VecMonitor(vec_env)
