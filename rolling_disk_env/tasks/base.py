"""What a task is, and the arrays its compiled formulas read and write.

A task is one module (see the recipe in :mod:`rolling_disk_env.tasks`): a :class:`Task` subclass, which checks the
task's options and describes its spaces, reward terms and ranges, and module-level kernels, pure functions of floats
and tuples of floats that numba compiles into the engine's fused step (``x`` is the state, 8 floats; ``goal`` the
episode's task variables, :attr:`Task.goal_names` then :attr:`Task.progress_names`; ``settings`` the task's options,
:attr:`Task.setting_names`):

* ``start(drawn, disk, settings) -> (goal, x)``: the episode's goal (its targets, then the initial values of its
  progress) and initial state from the values ``drawn`` uniformly in the task's goal ranges, then its initial-state
  ranges (an array, in their keys' order), for the disk ``(m, g, r)``;
* ``advance(x, trig, velocity, goal, settings) -> progress`` (only for a task with :attr:`Task.progress_names`): the
  task's state after a step, from the disk at the step's end and the goal before it: which waypoint comes next, how
  far along a path the disk is, how long it has held a pose. The step calls it once per disk and control period,
  after the integration and the contact checks, and writes it into the goal before the task's termination, reward
  terms and observation read it; the reset writes the initial values ``start`` gives. Its size is fixed (a row of
  the batch's ``goals`` per name), the same on every target (the vector env, the single env, the GPU and JAX);
* ``observe(x, trig, velocity, goal, settings)``: the observation (unclipped: the engine clips it to the bounds);
  ``trig`` is ``(sin theta, cos theta, sin psi, cos psi)`` of ``x`` (positions :data:`SIN_THETA` to :data:`COS_PSI`),
  which the engine keeps from the step (``kernels.angles``), ``velocity`` the centre's horizontal velocity
  ``(dc1, dc2)`` (m/s: from the rolling constraint, or the sliding disk's own under the ``"sliding"`` and
  ``"coulomb"`` contacts);
* ``reward_terms(x, trig, velocity, code, effort, goal, settings)``: each named term, in [-1, 1], in the order of
  :attr:`Task.default_reward_weights`; ``code`` is the step's termination code
  (:class:`rolling_disk_env.Termination`: RUNNING, the task's own, or the engine's, such as LIFTED_OFF), ``effort``
  the mean squared normalized action, in [0, 1]; the engine weights and sums them;
* ``termination(x, goal, settings)``: the engine's code :data:`~rolling_disk_env.engine.RUNNING`,
  :data:`~rolling_disk_env.engine.FALLEN`, :data:`~rolling_disk_env.engine.REACHED` or
  :data:`~rolling_disk_env.engine.OFF_COURSE`;
* ``tracking_error(x, goal, settings)``: the error whose exponentially weighted mean decides success (only for the
  success rule :data:`TRACK`).

The kernels the step calls (all but ``start``) are declared with :data:`rolling_disk_env.jit.inline_kernel`, so
that LLVM writes them into the step's loop: a call left in the loop keeps it from vectorizing.

Each module names the positions it reads in these tuples with constants (numba folds them), as :data:`THETA` and the
others do for the state. Use IEEE-exact operations (+, -, *, /, sqrt) and
:func:`rolling_disk_env.trig.sincos` in the kernels the step calls: a call to libm (``math.sin``, ``math.atan2``, ...)
keeps the step's loop over the disks from vectorizing (``start`` runs in the reset, which is not vectorized, and may
use libm). ``math.hypot``, for one, differs in the last bit between CPython and numba. A choice among values is a
conditional expression (``a if c else b``), which the loop computes without a branch and JAX reads as ``where``; an
index into a tuple is a constant (select among a tuple's items by conditional expressions).
"""

from __future__ import annotations

import hashlib
import inspect
import math
from abc import ABC
from typing import ClassVar

import numpy as np

from rolling_disk_env.constants import LEAN_LIMIT
from rolling_disk_env.dynamics import is_number, number_pair
from rolling_disk_env.jit import inline_kernel

C1, C2, PHI, THETA, PSI, DPHI, DTHETA, DPSI = range(8)
"""Positions in a state ``x`` (the paper's order)."""
SIN_THETA, COS_THETA, SIN_PSI, COS_PSI = range(4)
"""Positions in ``trig``, the sines and cosines of a state's angles."""
MASS, GRAVITY, RADIUS = range(3)
"""Positions in a disk ``(m, g, r)``."""

SURVIVE, TRACK, REACH = range(3)
"""Success rules: not falling; not falling with an exponentially weighted mean of the tracking error over the episode
(time constant ``success_time_constant``, :func:`rolling_disk_env.engine.track`) within ``success_bound``; reaching
the goal."""

RATE_BOUND = 100.0
"""rad/s. Observed rates are clipped to +-RATE_BOUND so that the observation space is bounded."""


def circle_points(x: float, y: float, radius: float, count: int = 96) -> np.ndarray:
    """A closed polyline of ``count`` points around the circle of centre ``(x, y)`` and ``radius`` (m), (count + 1, 2)
    (its first point repeated)."""
    angles = np.linspace(0.0, 2 * math.pi, count + 1)
    return np.column_stack([x + radius * np.cos(angles), y + radius * np.sin(angles)])


@inline_kernel
def penalty(error):
    """The bounded penalty ``-min(error^2, 1)`` of a normalized error (compiled into the tasks' kernels)."""
    return -min(error * error, 1.0)


class Task(ABC):
    """One task of RollingDisk-v0: options, spaces, names and ranges (the formulas are the module's kernels).

    Subclasses set the class attributes and register in :data:`rolling_disk_env.tasks.TASKS`.

    Attributes:
        name: the ``task=`` string.
        observation_names: one per observation component.
        default_reward_weights: the named reward terms, in the order ``reward_terms`` writes them, with their
            default weights (option ``reward_weights``).
        goal_names: the per-episode targets ``start`` writes, in order.
        progress_names: the per-episode task state that ``start`` sets and ``advance`` updates at every step, after
            the targets in ``goal`` (none by default).
        setting_names: the instance attributes the kernels read from ``settings``, in order.
        default_initial_ranges: initial-state ranges (option ``initial_ranges``), in the order ``start`` reads them.
        fall_lean: rad. The disk has fallen when |theta| exceeds it.
        success: the success rule, :data:`SURVIVE`, :data:`TRACK` or :data:`REACH`.
        success_bound: the bound of the success rule :data:`TRACK` (or of :data:`REACH`'s distance).
        success_time_constant: s. The time constant of the success rule :data:`TRACK`'s exponentially weighted mean:
            the error of a step t seconds ago weighs ``exp(-t / success_time_constant)`` against the latest's.
        contact: the contact model the task runs under (the env's ``contact`` defaults to it, and no other is
            accepted), or None: any, ``"rolling"`` by default.
        friction_coefficient: the env's ``friction_coefficient`` by default, with :attr:`contact`.
        mark_label: what the renderer's legend calls the task's marks (:meth:`marks`).
        steps_of: the task whose generated steps (``_generated/<name>.py``) this one runs: itself, or for a task that
            runs another's kernels and differs only in what the steps read at run time (its reward weights, options
            and ranges), that one's, so that it compiles nothing of its own.
    """

    name: ClassVar[str]
    observation_names: ClassVar[tuple[str, ...]]
    default_reward_weights: ClassVar[dict[str, float]]
    goal_names: ClassVar[tuple[str, ...]]
    progress_names: ClassVar[tuple[str, ...]] = ()
    setting_names: ClassVar[tuple[str, ...]]
    default_initial_ranges: ClassVar[dict[str, tuple[float, float]]]
    fall_lean: float
    success: ClassVar[int] = SURVIVE
    success_bound: float = math.inf
    success_time_constant: float = math.inf
    contact: ClassVar[str | None] = None
    friction_coefficient: ClassVar[float | None] = None
    mark_label: ClassVar[str] = "target"
    steps_of: ClassVar[str] = ""

    @classmethod
    def source_hash(cls) -> str:
        """The sha256 of the source of the task's module: its generated steps (``_generated/<name>.py``) record the
        hash they were generated from, so that steps older than the task are refused."""
        return hashlib.sha256(inspect.getsource(inspect.getmodule(cls)).encode()).hexdigest()

    def __init__(self, reward_weights: dict[str, float] | None = None, fall_lean: float | None = None):
        weights = dict(self.default_reward_weights)
        if not isinstance(reward_weights, (dict, type(None))):
            raise ValueError(f"reward_weights must be a dict of term names to numbers, got {reward_weights!r}")
        for key, value in (reward_weights or {}).items():
            if key not in weights:
                raise ValueError(f"unknown reward term {key!r} for task {self.name!r}; terms: {sorted(weights)}")
            if not (is_number(value) and math.isfinite(value)):
                raise ValueError(f"reward weight {key!r} must be a finite number, got {value!r}")
            weights[key] = float(value)
        self.reward_weights = weights
        if fall_lean is not None:
            if not (is_number(fall_lean) and 0 < fall_lean < LEAN_LIMIT):
                raise ValueError(f"fall_lean must be a number in (0, {LEAN_LIMIT:.4f}) rad, got {fall_lean!r}")
            self.fall_lean = float(fall_lean)

    def initial_ranges(self, overrides: dict[str, tuple[float, float]] | None) -> dict[str, tuple[float, float]]:
        """The task's initial-state ranges, updated by ``overrides``, checked: known keys, (low, high) pairs with
        low <= high, and leans ``theta`` within the fall threshold (so that no episode starts fallen, as a state
        given to ``reset`` may not either) and the model's domain."""
        if not isinstance(overrides, (dict, type(None))):
            raise ValueError(f"initial_ranges must be a dict of (low, high) pairs, got {overrides!r}")
        ranges = dict(self.default_initial_ranges)
        for key, bounds in (overrides or {}).items():
            if key not in ranges:
                raise ValueError(f"unknown initial-state range {key!r} for task {self.name!r}; keys: {sorted(ranges)}")
            low, high = number_pair(bounds, f"initial-state range {key!r}")
            if not (math.isfinite(low) and math.isfinite(high) and low <= high):
                raise ValueError(f"initial-state range {key!r} must be finite with low <= high, got {bounds!r}")
            ranges[key] = (low, high)
        if "theta" in ranges:
            lean = max(abs(bound) for bound in ranges["theta"])
            if lean >= LEAN_LIMIT:
                raise ValueError(
                    f"initial-state range 'theta' {ranges['theta']} leaves the model's domain "
                    f"|theta| < LEAN_LIMIT = {LEAN_LIMIT:.4f} rad"
                )
            if lean > self.fall_lean:
                raise ValueError(
                    f"initial-state range 'theta' {ranges['theta']} reaches past the fall threshold: keep |theta| <= "
                    f"fall_lean = {self.fall_lean} rad (task {self.name!r}; the task option fall_lean sets it)"
                )
        return ranges

    def check_disk(self, params) -> None:  # noqa: B027 (a hook: most tasks have a goal for every disk)
        """Raises ``ValueError`` if the task has no goal for a disk of these ``DiskParams`` (nothing to check here)."""

    def marks(self, goal: dict[str, float]) -> list[np.ndarray]:
        """What the renderer and the episode plots draw on the ground for an episode's ``goal`` (targets and
        progress, by name): polylines, each an (n, 2) array of points (m; a closed one repeats its first point).
        None by default."""
        return []

    @property
    def steps_name(self) -> str:
        """The name of the task whose generated steps this one runs (:attr:`steps_of`, else its own)."""
        return self.steps_of or self.name

    @property
    def goal_size(self) -> int:
        """Rows of an episode's goal: its targets, then its progress."""
        return len(self.goal_names) + len(self.progress_names)

    @property
    def goal_ranges(self) -> dict[str, tuple[float, float]]:
        """Per-episode values drawn uniformly from their ranges before the initial state's (none by default)."""
        return {}

    @property
    def settings(self) -> np.ndarray:
        """The options the kernels read: :attr:`setting_names` in order, float64."""
        return np.array([getattr(self, name) for name in self.setting_names], dtype=np.float64)

    @property
    def weights(self) -> np.ndarray:
        """The reward weights in the order of the terms, float64."""
        return np.array(list(self.reward_weights.values()), dtype=np.float64)

    @property
    def observation_high(self) -> np.ndarray:
        """Upper bounds of the observation (the lower bounds are their negatives), float32."""
        return np.array([self.observation_bound(name) for name in self.observation_names], dtype=np.float32)

    def observation_bound(self, name: str) -> float:
        """Bound of one observation component; rates default to :data:`RATE_BOUND`."""
        return RATE_BOUND
