"""N disks in the engine's arrays, stepped and reset by their task's compiled kernels: what both envs run.

The single env is a batch of one; the vector env a batch of N. Both call the same generated kernels
(``_generated/<task>.py``), so the same seeds give the same transitions to the last bit.
"""

from __future__ import annotations

import ctypes
import functools
import os
import platform
from dataclasses import dataclass

import numpy as np

from rolling_disk_env import engine
from rolling_disk_env.envs.config import EnvConfig
from rolling_disk_env.tasks.base import TRACK

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
"""glibc's mallopt parameter numbers."""
HEAP_FROM = 1024
"""Batches of this many disks or more make the process keep freed memory (:func:`keep_freed_memory`)."""


@functools.cache
def keep_freed_memory() -> bool:
    """Asks glibc's malloc to serve allocations up to 64 MiB from the heap and to keep up to 128 MiB of freed heap.

    Every step returns fresh arrays (the info block is 3 MB at N = 16384). By default glibc maps large allocations
    afresh and unmaps them when freed, so each step page-faults its outputs back in: measured at N = 16384
    (``circle``), a step took 3.3 ms instead of 1.6 ms. This sets ``M_MMAP_THRESHOLD`` and ``M_TRIM_THRESHOLD`` (what
    the environment variables ``MALLOC_MMAP_THRESHOLD_`` and ``MALLOC_TRIM_THRESHOLD_`` set, which are left alone if
    the user set either) once per process; elsewhere than glibc it does nothing. Returns whether it was set.
    """
    if {"MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"} & os.environ.keys() or platform.libc_ver()[0] != "glibc":
        return False
    try:
        libc = ctypes.CDLL(None)
        return bool(libc.mallopt(_M_MMAP_THRESHOLD, 64 * 2**20) and libc.mallopt(_M_TRIM_THRESHOLD, 128 * 2**20))
    except (OSError, AttributeError):
        return False


def columns(num_envs: int) -> int:
    """Columns of a batch's arrays of one column per disk: ``num_envs``, and from 256 disks on a few more (idle,
    never reported), so that a row spans an odd number of 64-byte cache lines. With rows of a power-of-two size, the
    dozens of rows a step reads and writes map to the same sets of the CPU's cache and evict each other: measured
    at N = 4096 and 16384, a step took 31 to 37 ns a disk against 27 at N = 4104 and 16392."""
    if num_envs < 256:
        return num_envs
    lines = -(-num_envs // 8)
    return 8 * (lines + 1 - lines % 2)


@dataclass
class Outputs:
    """What a step or a reset returns for N disks.

    Attributes:
        observations: (N, observation size), float32, clipped to the observation space.
        block: (engine.TERMS + terms + observation size, columns), float64, a column per disk (and padding, see
            :func:`columns`): the state, energy, contact forces, normal force, required friction, reward,
            termination code, reward terms (rows ``engine.ENERGY`` and the others), then the observation (which the
            step copies into ``observations``).
        flag_block: (3, columns), bool: terminated, truncated, success (rows ``engine.TERMINATED`` and the others).
    """

    observations: np.ndarray
    block: np.ndarray
    flag_block: np.ndarray

    @classmethod
    def empty(cls, num_envs: int, observation_size: int, terms: int, zeroed: bool = True) -> Outputs:
        """New arrays: zeros, or (``zeroed=False``, for a step, which writes every disk's) uninitialized."""
        make, width = (np.zeros if zeroed else np.empty), columns(num_envs)
        return cls(
            make((num_envs, observation_size), dtype=np.float32),
            make((engine.TERMS + terms + observation_size, width)),
            make((3, width), dtype=bool),
        )

    @property
    def info(self) -> np.ndarray:
        """The disks' columns of :attr:`block`, (rows, N)."""
        return self.block[:, : len(self.observations)]

    @property
    def flags(self) -> np.ndarray:
        """The disks' columns of :attr:`flag_block`, (3, N)."""
        return self.flag_block[:, : len(self.observations)]


class DiskBatch:
    """The state of N disks (in the engine's lanes array, with their goals and step counts) and the compiled step and
    reset of their task.

    Args:
        config: the env's checked settings.
        num_envs: N.
        max_episode_steps: steps before the engine truncates an episode (None: never; the single env leaves it to
            Gymnasium's TimeLimit wrapper).
    """

    def __init__(self, config: EnvConfig, num_envs: int, max_episode_steps: int | None):
        task = config.task
        steps = engine.task_steps(task)
        self._step = getattr(steps, f"step_{config.integrator}")
        self._reset = steps.reset
        self.num_envs = num_envs
        width = columns(num_envs)
        if num_envs >= HEAP_FROM:
            keep_freed_memory()
        self.terms = len(task.reward_weights)
        self.observation_size = len(task.observation_names)
        # Per disk.
        self.lanes = np.zeros((engine.LANES, width))
        self.lanes[engine.MASS : engine.RADIUS + 1] = np.array(config.params.constants)[:, None]
        self.goals = np.zeros((len(task.goal_names), width))
        self.steps = np.zeros(width, dtype=np.int64)
        # Tracking errors summed over each episode, a row per step, for the success rule TRACK; grown as needed.
        tracked = task.success == TRACK
        self.error_sums = np.zeros(((max_episode_steps or 1024) + 1 if tracked else 1, width))
        self.uniforms = np.zeros((num_envs, config.draws))
        self.no_state = np.full((num_envs, 8), np.nan)
        # Settings.
        self.config = config.engine_config(max_episode_steps)
        self.actuators = config.actuators_array
        self.disk_ranges = config.disk_ranges
        self.ranges = config.ranges
        self.settings = task.settings
        self.weights = task.weights
        self.bounds = task.observation_high
        self._no_rngs = np.zeros((0, 4), dtype=np.uint64)

    @property
    def states(self) -> np.ndarray:
        """The disks' states, (8, N): a view of the lanes."""
        return self.lanes[engine.STATE : engine.STATE + 8, : self.num_envs]

    @property
    def disks(self) -> np.ndarray:
        """The disks' constants (m, g, r), (3, N): a view of the lanes."""
        return self.lanes[engine.MASS : engine.RADIUS + 1, : self.num_envs]

    def outputs(self, zeroed: bool = True) -> Outputs:
        """New output arrays for the batch (see :meth:`Outputs.empty`)."""
        return Outputs.empty(self.num_envs, self.observation_size, self.terms, zeroed)

    def reset(
        self, mask: np.ndarray, out: Outputs, rngs: np.ndarray | None = None, states: np.ndarray | None = None
    ) -> None:
        """Starts new episodes in the disks of ``mask``, writing their outputs into ``out``.

        Args:
            mask: (N,), bool.
            out: where the disks' first observation and info go.
            rngs: (N, 4) uint64 PCG64 states to draw the episodes from (:mod:`rolling_disk_env.pcg64`); None to use
                the uniforms already in :attr:`uniforms`.
            states: (N, 8) initial states that replace the drawn ones (rows of NaN: none), or None.
        """
        self._reset(
            mask,
            self._no_rngs if rngs is None else rngs,
            self.uniforms,
            self.no_state if states is None else states,
            self.lanes,
            self.goals,
            self.steps,
            self.error_sums,
            self.config,
            self.disk_ranges,
            self.ranges,
            self.settings,
            self.bounds,
            out.observations,
            out.block,
            out.flag_block,
        )

    def step(self, actions: np.ndarray, out: Outputs) -> int:
        """Steps every disk under normalized ``actions`` (N, A), writing the outputs into ``out``.

        Returns:
            The first disk whose action is not finite (then nothing was stepped), or -1.
        """
        if len(self.error_sums) > 1 and self.steps[: self.num_envs].max() + 1 >= len(self.error_sums):
            self.error_sums = np.concatenate([self.error_sums, np.zeros_like(self.error_sums)])
        return self._step(
            actions,
            self.lanes,
            self.goals,
            self.steps,
            self.error_sums,
            self.config,
            self.actuators,
            self.settings,
            self.weights,
            self.bounds,
            out.observations,
            out.block,
            out.flag_block,
        )
