"""Keyword arguments of RollingDisk-v0, checked once, and what the single and the vector env share per episode."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from gymnasium import spaces

from rolling_disk_env.dynamics import DEFAULT_PARAMS, DiskParams, check_states
from rolling_disk_env.integrators import STEPS
from rolling_disk_env.tasks import TASKS, Task
from rolling_disk_env.tasks.base import SCALAR_MATH

ACTUATORS = ("spin", "steer")
"""Torque inputs, in the order of the dynamics' ``(tau_spin, tau_steer)``."""
RESET_OPTIONS = frozenset({"state"})


@dataclass(frozen=True)
class EnvConfig:
    """The environment's settings (see :class:`rolling_disk_env.envs.RollingDiskEnv` for their meaning)."""

    task: Task
    actuators: tuple[str, ...]
    dt: float
    integrator: str
    substeps: int
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
        max_spin_torque: float = 5.0,
        max_steer_torque: float = 10.0,
        params: DiskParams | None = None,
        params_ranges: dict[str, tuple[float, float]] | None = None,
        initial_ranges: dict[str, tuple[float, float]] | None = None,
        task_options: dict | None = None,
    ) -> EnvConfig:
        """Checks every argument and raises ``ValueError`` naming the first bad one."""
        if isinstance(task, Task):
            if task_options:
                raise ValueError("task_options apply to a task given by name, not to a Task instance")
        elif task in TASKS:
            task = TASKS[task](**(task_options or {}))
        else:
            raise ValueError(f"unknown task {task!r}; tasks: {sorted(TASKS)}")
        if isinstance(actuators, str):
            raise ValueError(f"actuators must be a tuple of names from {ACTUATORS}, got the string {actuators!r}")
        actuators = tuple(actuators)
        unknown = [a for a in actuators if a not in ACTUATORS]
        if unknown or len(set(actuators)) != len(actuators):
            raise ValueError(f"actuators must be distinct names from {ACTUATORS}, got {actuators!r}")
        actuators = tuple(a for a in ACTUATORS if a in actuators)
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a finite number > 0 (s), got {dt!r}")
        if integrator not in STEPS:
            raise ValueError(f"integrator must be a fixed-step method, one of {sorted(STEPS)}, got {integrator!r}")
        if not (isinstance(substeps, int) and substeps >= 1):
            raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
        for name, value in (("max_spin_torque", max_spin_torque), ("max_steer_torque", max_steer_torque)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0 (N m), got {value!r}")
        params = params or DEFAULT_PARAMS
        if not isinstance(params, DiskParams):
            raise ValueError(f"params must be a DiskParams, got {type(params).__name__}")
        checked_ranges = {}
        names = [f.name for f in fields(DiskParams)]
        for key, bounds in (params_ranges or {}).items():
            if key not in names:
                raise ValueError(f"unknown key {key!r} in params_ranges; keys: {names}")
            low, high = (float(b) for b in bounds)
            if not (math.isfinite(high) and 0 < low <= high):
                raise ValueError(f"params_ranges[{key!r}] must satisfy 0 < low <= high, got {bounds!r}")
            checked_ranges[key] = (low, high)
        return cls(
            task=task,
            actuators=actuators,
            dt=float(dt),
            integrator=integrator,
            substeps=substeps,
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
    def actuator_rows(self) -> list[int]:
        """For each action component, its row in ``(tau_spin, tau_steer)``."""
        return [ACTUATORS.index(name) for name in self.actuators]

    @property
    def actuator_limits(self) -> list[float]:
        """For each action component, the torque (N m) of action +1."""
        return [self.max_torque[row] for row in self.actuator_rows]

    @property
    def torque_scale(self) -> np.ndarray:
        """Matrix mapping a normalized action (n,) to ``(tau_spin, tau_steer)`` in N m, shape (2, n)."""
        scale = np.zeros((2, len(self.actuators)))
        scale[self.actuator_rows, range(len(self.actuators))] = self.actuator_limits
        return scale

    @property
    def draws(self) -> int:
        """How many uniform numbers an episode draws: one per range of the disk, the goal and the initial state."""
        return len(self.params_ranges) + len(self.task.goal_ranges) + len(self.initial_ranges)

    def episode(self, uniforms, xp) -> tuple[tuple, dict, list]:
        """An episode's disk constants ``(m, g, r)``, goal and initial state, from :attr:`draws` uniforms in [0, 1).

        The uniforms are floats for one episode (``xp`` is then ``tasks.base.SCALAR_MATH``) or rows of shape (n,)
        for n episodes (``xp`` is ``tasks.base.BATCHED_MATH``), taken in this order: ``params_ranges``, the task's
        ``goal_ranges``, ``initial_ranges``, each in its keys' order; a value is ``low + (high - low) u``.
        """
        values = iter(uniforms)

        def scale(ranges: dict) -> dict:
            return {key: low + (high - low) * next(values) for key, (low, high) in ranges.items()}

        disk = scale(self.params_ranges)
        mass, gravity, radius = self.params.constants
        constants = (disk.get("mass", mass), disk.get("gravity", gravity), disk.get("radius", radius))
        goal = self.task.goal(scale(self.task.goal_ranges), constants, xp)
        return constants, goal, self.task.initial_state(scale(self.initial_ranges), constants, goal, xp)

    def sample_episode(self, rng: np.random.Generator, options: dict | None) -> tuple[DiskParams, dict, list[float]]:
        """Draws one episode's disk, goal and initial state (floats) with a single call of ``rng``;
        ``options["state"]`` then sets the state exactly."""
        state = self.reset_state(options)
        (mass, gravity, radius), goal, drawn = self.episode(rng.random(self.draws).tolist(), SCALAR_MATH)
        params = DiskParams(mass=mass, radius=radius, gravity=gravity) if self.params_ranges else self.params
        goal = {key: float(value) for key, value in goal.items()}
        return params, goal, [float(v) for v in drawn] if state is None else state.tolist()

    def reset_state(self, options: dict | None, num_envs: int | None = None) -> np.ndarray | None:
        """The checked initial state(s) ``options["state"]`` of shape (8,), or (num_envs, 8) for a vector env; or
        None. Raises ``ValueError`` on an unknown option, a wrong shape, a state outside the model's domain or a
        disk that has already fallen."""
        options = options or {}
        unknown = options.keys() - RESET_OPTIONS
        if unknown:
            raise ValueError(f"unknown reset option(s) {sorted(unknown)}; options: {sorted(RESET_OPTIONS)}")
        if "state" not in options:
            return None
        state = check_states(options["state"], name='options["state"]')
        expected = (8,) if num_envs is None else (num_envs, 8)
        if state.shape != expected:
            raise ValueError(f'options["state"] must have shape {expected}, got {state.shape}')
        fallen = np.flatnonzero(self.task.fallen(np.atleast_2d(state).T, np))
        if fallen.size:
            theta = np.atleast_2d(state)[fallen[0], 3]
            raise ValueError(
                f'options["state"] has |theta| = {abs(theta):.4g} rad: the disk has already fallen '
                f"(fall_lean = {self.task.fall_lean} rad for task {self.task.name!r})"
            )
        return state


def action_error(action, expected: tuple[int, ...]) -> str | None:
    """Why ``action`` is not a valid action of shape ``expected``, or None."""
    array = np.asarray(action)
    if array.shape != expected:
        return f"action must have shape {expected}, got {array.shape}"
    if not np.issubdtype(array.dtype, np.number) or not np.all(np.isfinite(array)):
        return f"action must be finite numbers, got {array!r}"
    return None
