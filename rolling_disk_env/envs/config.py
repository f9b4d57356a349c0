"""Keyword arguments of RollingDisk-v0, checked once, and what the single and the vector env share per episode."""

from __future__ import annotations

import enum
import inspect
import itertools
import math
from dataclasses import dataclass, fields

import numpy as np
from gymnasium import spaces

from rolling_disk_env import engine
from rolling_disk_env.constants import CONTACTS
from rolling_disk_env.dynamics import (
    DEFAULT_PARAMS,
    FULL_MODEL,
    ROLLING_INDICES,
    SLIDING_MODEL,
    DiskParams,
    check_friction_coefficient,
    check_states,
    is_number,
    number_pair,
)
from rolling_disk_env.tasks import TASKS, Task

ACTUATORS = ("spin", "steer")
"""Torque inputs, in the order of the dynamics' ``(tau_spin, tau_steer)``."""
RESET_OPTIONS = frozenset({"state"})
DRAWN = ("mass", "gravity", "radius", "friction_coefficient")
"""The disk's constants that ``params_ranges`` may draw per episode, in the order of the lanes rows
``engine.MASS`` to ``engine.MU`` and of the draws."""
PAINLEVE_BOUND = math.sqrt(5) / 2
"""The sliding model's normal force stays finite for friction coefficients below sqrt(5)/2 (Painleve's paradox
above: see ``rolling_disk_env/_generated/sliding.py``)."""


class Termination(enum.IntEnum):
    """``info["termination"]``, an int at every step: why the episode terminated, or ``NONE``
    (``Termination(code).name`` names a code; the values are the engine's codes, :data:`rolling_disk_env.engine.RUNNING`
    and after).

    A number, not a name, so that every wrapper that batches infos stacks it: Gymnasium's vector envs into an int array,
    Tianshou's buffers, and TorchRL's info reader, which takes every info key of a vector env as a tensor."""

    NONE = engine.RUNNING
    """The episode has not terminated: it runs on, or was truncated."""
    FALLEN = engine.FALLEN
    """The lean passed the task's ``fall_lean``."""
    OUT_OF_DOMAIN = engine.OUT_OF_DOMAIN
    """The integration left the model's domain (a lean beyond :data:`rolling_disk_env.LEAN_LIMIT`, near the flat
    disk where the model is singular, or a value that is not finite); the state is the one at the start of the
    step."""
    SLIPPED = engine.SLIPPED
    """Rolling needed more friction than ``friction_coefficient`` (``contact="rolling"`` with a finite one)."""
    LIFTED_OFF = engine.LIFTED_OFF
    """The normal force vanished: the disk would leave the ground."""
    SUBSTEP_LIMIT = engine.SUBSTEP_LIMIT
    """``"dopri5"`` took :data:`rolling_disk_env.engine.MAX_ADAPTIVE_SUBSTEPS` steps in one control period."""
    REACHED = engine.REACHED
    """The task's goal was reached (``goto``, ``ice``: the target; ``waypoints``: the last waypoint; ``eight``: a
    whole figure eight; ``recovery``: upright rolling held)."""
    OFF_COURSE = engine.OFF_COURSE
    """The disk strayed past the task's tracking bound (``eight``: too far from the path)."""


def task_option_names(task_class: type[Task]) -> list[str]:
    """The ``task_options`` a task class takes: the keyword arguments of its ``__init__`` and its bases'."""
    names = set()
    for klass in task_class.__mro__[:-1]:  # without object
        if "__init__" in vars(klass):
            parameters = inspect.signature(klass.__init__).parameters.values()
            names |= {p.name for p in parameters if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    return sorted(names - {"self"})


@dataclass(frozen=True)
class EnvConfig:
    """The environment's settings (see :class:`rolling_disk_env.envs.RollingDiskEnv` for their meaning)."""

    task: Task
    actuators: tuple[str, ...]
    dt: float
    integrator: str
    substeps: int
    rtol: float
    atol: float
    friction_coefficient: float | None
    contact: str
    max_torque: tuple[float, float]
    params: DiskParams
    params_ranges: dict[str, tuple[float, float]]
    initial_ranges: dict[str, tuple[float, float]]

    @classmethod
    def from_kwargs(
        cls,
        task: str | Task = "upright",
        actuators: tuple[str, ...] | list[str] = ACTUATORS,
        dt: float = 0.02,
        integrator: str = "rk4",
        substeps: int = 1,
        rtol: float = 1e-6,
        atol: float = 1e-8,
        friction_coefficient: float | None = None,
        contact: str | None = None,
        max_spin_torque: float = 5.0,
        max_steer_torque: float = 10.0,
        params: DiskParams | None = None,
        params_ranges: dict[str, tuple[float, float]] | None = None,
        initial_ranges: dict[str, tuple[float, float]] | None = None,
        task_options: dict | None = None,
        **unknown,
    ) -> EnvConfig:
        """Checks every argument and raises ``ValueError`` naming the first bad one (``TypeError`` for an unknown
        keyword argument, worded as Python words it, ``got an unexpected keyword argument 'NAME'``, which wrappers
        such as TorchRL's ``GymEnv`` probe for before retrying without an optional argument, and listing the valid
        ones)."""
        if unknown:
            valid = sorted([*(inspect.signature(cls.from_kwargs).parameters.keys() - {"unknown"}), "render_mode"])
            names = " and ".join(f"an unexpected keyword argument {name!r}" for name in sorted(unknown))
            raise TypeError(f"RollingDisk-v0 got {names}; valid keyword arguments: {valid}")
        if isinstance(task, Task):
            if task_options:
                raise ValueError("task_options apply to a task given by name, not to a Task instance")
        elif task in TASKS:
            if not isinstance(task_options, (dict, type(None))):
                raise ValueError(f"task_options must be a dict of the task's arguments, got {task_options!r}")
            valid = task_option_names(TASKS[task])
            unknown_options = sorted((task_options or {}).keys() - set(valid))
            if unknown_options:
                raise ValueError(f"unknown task option(s) {unknown_options} for task {task!r}; options: {valid}")
            task = TASKS[task](**(task_options or {}))
        else:
            raise ValueError(f"unknown task {task!r}; tasks: {sorted(TASKS)}")
        if contact is None:
            contact = task.contact or "rolling"
        elif task.contact is not None and contact != task.contact:
            raise ValueError(f"task {task.name!r} runs under contact={task.contact!r}, got contact={contact!r}")
        if friction_coefficient is None and task.contact is not None:
            friction_coefficient = task.friction_coefficient
        if isinstance(actuators, str):
            raise ValueError(f"actuators must be a tuple of names from {ACTUATORS}, got the string {actuators!r}")
        actuators = tuple(actuators)
        unknown = [a for a in actuators if a not in ACTUATORS]
        if unknown or len(set(actuators)) != len(actuators):
            raise ValueError(f"actuators must be distinct names from {ACTUATORS}, got {actuators!r}")
        actuators = tuple(a for a in ACTUATORS if a in actuators)
        if not (is_number(dt) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a finite number > 0 (s), got {dt!r}")
        if integrator not in engine.METHODS:
            raise ValueError(f"integrator must be one of {list(engine.METHODS)}, got {integrator!r}")
        for name, value in (("rtol", rtol), ("atol", atol)):
            if not (is_number(value) and 0 < value < 1):
                raise ValueError(f"{name} must be a number in (0, 1), got {value!r}")
        if contact not in CONTACTS:
            raise ValueError(f"contact must be one of {list(CONTACTS)}, got {contact!r}")
        if contact == "rolling":
            if friction_coefficient is not None and not (
                is_number(friction_coefficient) and 0 < friction_coefficient < math.inf
            ):
                raise ValueError(
                    f"friction_coefficient must be None or a finite number > 0, got {friction_coefficient!r}"
                )
        else:
            if friction_coefficient is None and contact == "coulomb":
                raise ValueError("contact='coulomb' needs a friction_coefficient: a finite number >= 0")
            mu = 0.0 if friction_coefficient is None else check_friction_coefficient(friction_coefficient)
            if not mu < PAINLEVE_BOUND:
                raise ValueError(
                    f"friction_coefficient must be below sqrt(5)/2 = {PAINLEVE_BOUND:.4f} under contact={contact!r} "
                    f"(above it the sliding disk's normal force can have no finite value), got {friction_coefficient!r}"
                )
            friction_coefficient = mu
            if integrator != "rk4":
                raise ValueError(
                    f"contact={contact!r} integrates with integrator='rk4' (its switching events are located within "
                    f"each step; substeps sets the steps per control period), got integrator={integrator!r}"
                )
        if not (isinstance(substeps, (int, np.integer)) and not isinstance(substeps, bool) and substeps >= 1):
            raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
        for name, value in (("max_spin_torque", max_spin_torque), ("max_steer_torque", max_steer_torque)):
            if not (is_number(value) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0 (N m), got {value!r}")
        params = params or DEFAULT_PARAMS
        if not isinstance(params, DiskParams):
            raise ValueError(f"params must be a DiskParams, got {type(params).__name__}")
        checked_ranges = {}
        names = [f.name for f in fields(DiskParams)]
        if not isinstance(params_ranges, (dict, type(None))):
            raise ValueError(f"params_ranges must be a dict of (low, high) pairs, got {params_ranges!r}")
        for key, bounds in (params_ranges or {}).items():
            if key not in (*names, "friction_coefficient"):
                raise ValueError(f"unknown key {key!r} in params_ranges; keys: {[*names, 'friction_coefficient']}")
            low, high = number_pair(bounds, f"params_ranges[{key!r}]")
            if key == "friction_coefficient":
                if contact == "rolling":
                    raise ValueError(
                        "params_ranges['friction_coefficient'] draws the friction coefficient of the 'sliding' and "
                        "'coulomb' contacts, not of contact='rolling' (whose friction_coefficient is one number)"
                    )
                if not (0 <= low <= high < PAINLEVE_BOUND):
                    raise ValueError(
                        f"params_ranges['friction_coefficient'] must satisfy 0 <= low <= high < sqrt(5)/2 = "
                        f"{PAINLEVE_BOUND:.4f}, got {bounds!r}"
                    )
            elif not (math.isfinite(high) and 0 < low <= high):
                raise ValueError(f"params_ranges[{key!r}] must satisfy 0 < low <= high, got {bounds!r}")
            checked_ranges[key] = (low, high)
        # The task's goal must exist for every disk drawn: check the corners of the disks' ranges.
        for corner in itertools.product(*(checked_ranges.get(name, (getattr(params, name),) * 2) for name in names)):
            task.check_disk(DiskParams(*corner))
        return cls(
            task=task,
            actuators=actuators,
            dt=float(dt),
            integrator=integrator,
            substeps=int(substeps),
            rtol=float(rtol),
            atol=float(atol),
            friction_coefficient=None if friction_coefficient is None else float(friction_coefficient),
            contact=contact,
            max_torque=(float(max_spin_torque), float(max_steer_torque)),
            params=params,
            params_ranges=checked_ranges,
            initial_ranges=task.initial_ranges(initial_ranges),
        )

    @property
    def action_space(self) -> spaces.Box:
        """One normalized torque per actuator, in [-1, 1]."""
        return spaces.Box(-1.0, 1.0, shape=(len(self.actuators),), dtype=np.float32)

    @property
    def observation_space(self) -> spaces.Box:
        high = self.task.observation_high
        return spaces.Box(-high, high, dtype=np.float32)

    @property
    def actuators_array(self) -> np.ndarray:
        """For each action component: its row in ``(tau_spin, tau_steer)`` and the torque (N m) of action +1."""
        rows = [ACTUATORS.index(name) for name in self.actuators]
        return np.array([[row, self.max_torque[row]] for row in rows], dtype=np.float64).reshape(-1, 2)

    @property
    def friction(self) -> float:
        """The contact's friction coefficient as the engine reads it: ``friction_coefficient``, inf for None."""
        return math.inf if self.friction_coefficient is None else self.friction_coefficient

    @property
    def disk_ranges(self) -> np.ndarray:
        """``(m, g, r, mu)`` rows of ``(low, high, drawn)`` (:data:`DRAWN`'s order): drawn ones from
        ``params_ranges``, the others fixed."""
        rows = []
        for name, value in zip(DRAWN, (*self.params.constants, self.friction)):
            low, high = self.params_ranges.get(name, (value, value))
            rows.append((low, high, float(name in self.params_ranges)))
        return np.array(rows, dtype=np.float64)

    @property
    def drawn_names(self) -> tuple[str, ...]:
        """The disk's constants drawn per episode (keys of ``params_ranges``), in :data:`DRAWN`'s order: the info keys
        that report them."""
        return tuple(name for name in DRAWN if name in self.params_ranges)

    @property
    def ranges(self) -> np.ndarray:
        """``(low, high)`` rows of the task's goal ranges, then its initial-state ranges, in their keys' order."""
        ranges = [*self.task.goal_ranges.values(), *self.initial_ranges.values()]
        return np.array(ranges, dtype=np.float64).reshape(-1, 2)

    @property
    def draws(self) -> int:
        """How many uniform numbers an episode draws: one per range of the disk, the goal and the initial state."""
        return len(self.params_ranges) + len(self.ranges)

    def engine_config(self, max_episode_steps: int | None) -> np.ndarray:
        """The ``config`` array of the engine's steps (its layout: ``engine.PERIOD`` and the others)."""
        values = {
            engine.PERIOD: self.dt,
            engine.SUBSTEPS: self.substeps,
            engine.RTOL: self.rtol,
            engine.ATOL: self.atol,
            engine.FRICTION: self.friction,
            engine.CONTACT: float(CONTACTS.index(self.contact)),
            engine.MAX_STEPS: max_episode_steps or 0,
            engine.SUCCESS_BOUND: self.task.success_bound,
            engine.SUCCESS_DECAY: math.exp(-self.dt / self.task.success_time_constant),
        }
        return np.array([values[key] for key in sorted(values)], dtype=np.float64)

    @property
    def state_size(self) -> int:
        """Numbers in a state: 8 (rolling), or 10 under the ``"sliding"`` and ``"coulomb"`` contacts."""
        return 8 if self.contact == "rolling" else SLIDING_MODEL.size

    def reset_state(self, options: dict | None, num_envs: int | None = None) -> np.ndarray | None:
        """The checked initial state(s) ``options["state"]`` of shape (8,), or (num_envs, 8) for a vector env; under
        the ``"sliding"`` and ``"coulomb"`` contacts also (10,) or (num_envs, 10), returned as 10-states with NaN
        centre velocities for rolling 8-states (the engine takes them from the rolling constraint); or None. Raises
        ``ValueError`` on an unknown option, a wrong shape, a state outside the model's domain or a disk that has
        already fallen."""
        options = options or {}
        unknown = options.keys() - RESET_OPTIONS
        if unknown:
            raise ValueError(f"unknown reset option(s) {sorted(unknown)}; options: {sorted(RESET_OPTIONS)}")
        if "state" not in options:
            return None
        sizes = (8,) if self.contact == "rolling" else (8, SLIDING_MODEL.size)
        shapes = [(size,) if num_envs is None else (num_envs, size) for size in sizes]
        given = np.shape(options["state"])
        if given not in shapes:
            also = "" if self.contact != "rolling" else " (10-states need contact='sliding' or 'coulomb')"
            raise ValueError(f'options["state"] must have shape {" or ".join(map(str, shapes))}, got {given}{also}')
        model = SLIDING_MODEL if given[-1] == SLIDING_MODEL.size else FULL_MODEL
        state = check_states(options["state"], model, name='options["state"]')
        fallen = np.flatnonzero(np.abs(np.atleast_2d(state)[:, 3]) > self.task.fall_lean)
        if fallen.size:
            theta = np.atleast_2d(state)[fallen[0], 3]
            raise ValueError(
                f'options["state"] has |theta| = {abs(theta):.4g} rad: the disk has already fallen '
                f"(fall_lean = {self.task.fall_lean} rad for task {self.task.name!r})"
            )
        if self.contact == "rolling" or model is SLIDING_MODEL:
            return state
        rows = np.full((*state.shape[:-1], SLIDING_MODEL.size), np.nan)
        rows[..., list(ROLLING_INDICES)] = state
        return rows


def checked_actions(actions, shape: tuple[int, ...], name: str = "action") -> np.ndarray:
    """``actions`` as the engine takes them: float32, of ``shape``, finite, clipped to [-1, 1].

    Raises ``ValueError``, naming ``name``, for a wrong shape, for values that are not real numbers (ints or floats:
    bools, complex numbers and strings are refused, not cast) and for NaN or inf. Finite values beyond float32's
    range are clipped like any other out-of-range value (before the cast, which would make them inf)."""
    array = np.asarray(actions)
    if array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be finite numbers (ints or floats), got a {array.dtype} array: {array!r}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite numbers, got {array!r}")
    return np.clip(array, -1.0, 1.0).astype(np.float32)
