"""What a task is: its initial states, observation, named reward terms, fall threshold and success rule.

A task's formulas are written once and run on one disk or on N disks: ``x`` is a sequence of the 8 state components
(floats for one disk, rows of shape (N,) for N disks), ``goal`` a dict of per-episode targets (floats or arrays), and
``xp`` the namespace of elementwise functions, :data:`SCALAR_MATH` or :data:`BATCHED_MATH` (numpy works too).
Episodes are drawn the same way: the env draws each range's value uniformly
(:meth:`rolling_disk_env.envs.config.EnvConfig.episode`) and the task turns the values into a goal and a state.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from types import SimpleNamespace
from typing import ClassVar

import numpy as np

from rolling_disk_env import trig
from rolling_disk_env.dynamics import LEAN_LIMIT

SCALAR_MATH = SimpleNamespace(sin=math.sin, cos=math.cos, sqrt=math.sqrt, minimum=min, abs=abs)
"""numpy's names for the functions the tasks use, on floats."""
BATCHED_MATH = SimpleNamespace(sin=trig.sin, cos=trig.cos, sqrt=np.sqrt, minimum=np.minimum, abs=np.abs)
"""The same on arrays: numpy's, with the batched path's sine and cosine (:mod:`rolling_disk_env.trig`)."""

RATE_BOUND = 100.0
"""rad/s. Observed rates are clipped to +-RATE_BOUND so that the observation space is bounded."""


class Task(ABC):
    """One task of RollingDisk-v0.

    Subclasses set the class attributes and implement the abstract methods; register them in
    :data:`rolling_disk_env.tasks.TASKS`.

    Attributes:
        name: the ``task=`` string.
        needs_position: whether the observation or reward reads c1, c2 (else the lean model would suffice).
        observation_names: one per observation component.
        reward_weights: weight of each named reward term; every term lies in [-1, 1] per step.
        fall_lean: rad. The episode terminates when |theta| exceeds it.
        success_bound: if set, success also needs the mean of :meth:`tracking_error` over the last half of the
            episode to stay at or below it; otherwise success is reaching truncation without falling.
    """

    name: ClassVar[str]
    needs_position: ClassVar[bool]
    observation_names: ClassVar[tuple[str, ...]]
    default_reward_weights: ClassVar[dict[str, float]]
    default_initial_ranges: ClassVar[dict[str, tuple[float, float]]]
    fall_lean: float
    success_bound: float | None = None

    def __init__(self, reward_weights: dict[str, float] | None = None, fall_lean: float | None = None):
        weights = dict(self.default_reward_weights)
        for key, value in (reward_weights or {}).items():
            if key not in weights:
                raise ValueError(f"unknown reward term {key!r} for task {self.name!r}; terms: {sorted(weights)}")
            if not math.isfinite(value):
                raise ValueError(f"reward weight {key!r} must be finite, got {value!r}")
            weights[key] = float(value)
        self.reward_weights = weights
        if fall_lean is not None:
            if not 0 < fall_lean < LEAN_LIMIT:
                raise ValueError(f"fall_lean must lie in (0, {LEAN_LIMIT:.4f}) rad, got {fall_lean!r}")
            self.fall_lean = float(fall_lean)

    def initial_ranges(self, overrides: dict[str, tuple[float, float]] | None) -> dict[str, tuple[float, float]]:
        """The task's initial-state ranges, updated by ``overrides`` (checked: known keys, low <= high)."""
        ranges = dict(self.default_initial_ranges)
        for key, bounds in (overrides or {}).items():
            if key not in ranges:
                raise ValueError(f"unknown initial-state range {key!r} for task {self.name!r}; keys: {sorted(ranges)}")
            low, high = (float(b) for b in bounds)
            if not (math.isfinite(low) and math.isfinite(high) and low <= high):
                raise ValueError(f"initial-state range {key!r} must be finite with low <= high, got {bounds!r}")
            ranges[key] = (low, high)
        return ranges

    @property
    def observation_high(self) -> np.ndarray:
        """Upper bounds of the observation (the lower bounds are their negatives), float32."""
        return np.array([self.observation_bound(name) for name in self.observation_names], dtype=np.float32)

    def observation_bound(self, name: str) -> float:
        """Bound of one observation component; rates default to :data:`RATE_BOUND`."""
        return RATE_BOUND

    @property
    def goal_ranges(self) -> dict[str, tuple[float, float]]:
        """Per-episode goal values drawn uniformly from their ranges (none by default)."""
        return {}

    @abstractmethod
    def goal(self, drawn: dict, constants: tuple, xp) -> dict:
        """The episode's targets, from the values ``drawn`` in :attr:`goal_ranges` and the disk's ``(m, g, r)``."""

    @abstractmethod
    def initial_state(self, drawn: dict, constants: tuple, goal: dict, xp) -> list:
        """The initial state's 8 components, from the values ``drawn`` in the initial-state ranges."""

    @abstractmethod
    def observe(self, x, goal: dict, xp) -> list:
        """The observation's components, unclipped."""

    @abstractmethod
    def reward_terms(self, x, effort, goal: dict, xp) -> dict:
        """Each named term, in [-1, 1]; ``effort`` is the mean squared normalized action, in [0, 1]."""

    def tracking_error(self, x, goal: dict, xp):
        """The error whose mean over the last half of an episode decides success (with ``success_bound``)."""
        raise NotImplementedError(f"task {self.name!r} has no tracking error")

    @staticmethod
    def penalty(error, xp):
        """The bounded penalty ``-min(error^2, 1)`` of a normalized error (float or array)."""
        return -xp.minimum(error * error, 1.0)

    def reward(self, terms: dict):
        """The weighted sum of the terms."""
        total = 0.0
        for name, value in terms.items():
            total = total + self.reward_weights[name] * value
        return total

    def fallen(self, x, xp):
        """Whether the disk has fallen: |theta| > fall_lean."""
        return xp.abs(x[3]) > self.fall_lean
