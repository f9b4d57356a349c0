"""RollingDisk-v0: one disk, stepped through the scalar path of the generated equations."""

from __future__ import annotations

import math
from collections import deque
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from rolling_disk_env._generated import scalar
from rolling_disk_env.dynamics import FULL_MODEL, LEAN_LIMIT
from rolling_disk_env.envs.config import EnvConfig, action_error
from rolling_disk_env.integrators import scalar_step
from rolling_disk_env.tasks.base import SCALAR_MATH

TRACK_LENGTH = 5000
"""Points of the centre's track kept for rendering."""


class RollingDiskEnv(gym.Env[np.ndarray, np.ndarray]):
    """A thin disk rolling without slipping on a plane, driven by a spin and a steer torque.

    ## Description

    The disk of L. Jaulin's *Modelisation of a rolling disk with Sympy*: state
    ``x = (c1, c2, phi, theta, psi, dphi, dtheta, dpsi)`` (centre position in m; spin, lean and heading in rad; their
    rates in rad/s), exact rolling-without-slipping dynamics derived with SymPy, no energy loss. Two optional
    actuators apply physical torques to the disk: ``spin`` about its symmetry axis and ``steer`` about the vertical.
    The lean theta has no actuator of its own: torques reach it through gyroscopic coupling.

    ## Action Space

    ``Box(-1, 1, (n,), float32)``, one component per actuator in the order ``("spin", "steer")`` (those enabled),
    scaled to ``max_spin_torque`` and ``max_steer_torque`` (N m). Finite actions outside [-1, 1] are clipped; NaN,
    inf or a wrong shape raise ``ValueError``. With ``actuators=()`` the space is empty and the disk is passive.

    ## Observation Space

    ``Box(float32)`` holding only what the task needs, relative to its target, clipped to its bounds (rates to
    +-100 rad/s). ``task="upright"``:

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | lean theta (rad) | -pi/2 | pi/2 |
    | 1 | lean rate dtheta (rad/s) | -100 | 100 |
    | 2 | spin-rate error dphi - dphi* (rad/s) | -100 | 100 |
    | 3 | heading rate dpsi (rad/s) | -100 | 100 |

    ``task="circle"``:

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | radial error of the centre, \\|c - centre\\| - R (m) | -10 | 10 |
    | 1 | sin of the heading error to the circle's tangent | -1 | 1 |
    | 2 | cos of the heading error | -1 | 1 |
    | 3 | lean error theta - theta* (rad) | -pi | pi |
    | 4 | lean rate dtheta (rad/s) | -100 | 100 |
    | 5 | spin-rate error dphi - dphi* (rad/s) | -100 | 100 |
    | 6 | heading-rate error dpsi - dpsi* (rad/s) | -100 | 100 |
    | 7 | target lean theta* of the episode's circle (rad) | -pi/2 | pi/2 |

    ## Rewards

    A weighted sum of named terms, each in [-1, 1] per step, reported in ``info["rewards"]``; the weights are the
    task option ``reward_weights``. ``upright``: ``alive`` +1, ``lean`` -(theta / 0.5)^2, ``speed``
    -min(((dphi - dphi*) / dphi*)^2, 1), ``effort`` -mean(action^2); weights 1, 1, 0.5, 0.1. ``circle``: ``alive``
    +1, ``radial`` -min(e_r^2, 1) (e_r in m), ``speed`` as above, ``effort``; weights 1, 1, 0.3, 0.1.

    ## Starting State

    ``upright``: at the origin, lean and rates drawn from ``initial_ranges`` (default theta in [-0.05, 0.05] rad,
    dtheta and dpsi in [-0.1, 0.1] rad/s, dphi in [0.8, 1.2] rad/s: slower than the self-stabilizing
    sqrt(g / 3r) = 1.81 rad/s, so a passive disk falls); phi and psi uniform. ``circle``: near a circle of radius R
    drawn from [3, 6] m, tangent to it, vertical and rolling straight at the target speed (2 m/s). The task
    modules document every range. ``reset(options={"state": x0})`` starts from an exact state instead.

    ## Episode End

    Termination: the disk has fallen, |theta| > ``fall_lean`` (0.5 rad for ``upright``, 0.8 rad for ``circle``;
    the model itself holds up to pi/2 - 0.01), or, which the default settings never do, the integrator left the
    model's domain; ``info["termination"]`` says which (``"fallen"`` or ``"out_of_domain"``). Truncation: after
    ``max_episode_steps`` (500 steps of 0.02 s, 10 s), by the ``TimeLimit`` wrapper of ``gymnasium.make``.

    ``info`` holds ``"state"`` (the 8-vector, float64), ``"energy"`` (J), ``"contact_force"`` (lambda1, lambda2 in
    N), ``"rewards"`` and ``"is_success"``: whether the episode counts as a success if
    it ends at this step (``upright``: not fallen; ``circle``: not fallen and a mean radial error over the last half
    of the episode of at most 0.25 m).

    ## Arguments

    ```python
    import gymnasium as gym
    import rolling_disk_env

    env = gym.make("RollingDisk-v0", task="circle", render_mode="rgb_array")
    ```

    | Parameter | Type | Default | Description |
    |-----------|------|---------|-------------|
    | `task` | str or Task | `"upright"` | `"upright"` or `"circle"` (or a `Task` instance) |
    | `actuators` | tuple of str | `("spin", "steer")` | enabled torques; `()` gives a passive disk |
    | `dt` | float | `0.02` | control period, s (also `1 / render_fps`) |
    | `integrator` | str | `"rk4"` | `"euler"`, `"symplectic_euler"` or `"rk4"` |
    | `substeps` | int | `1` | integrator steps per control period |
    | `max_spin_torque` | float | `5.0` | torque of action +1 on spin, N m |
    | `max_steer_torque` | float | `10.0` | torque of action +1 on steer, N m |
    | `params` | DiskParams | `DiskParams()` | mass 5 kg, radius 1 m, gravity 9.81 m/s^2 |
    | `params_ranges` | dict | `None` | per-episode uniform ranges, e.g. `{"mass": (4, 6), "radius": (0.8, 1.2)}` |
    | `initial_ranges` | dict | `None` | overrides of the task's initial-state ranges (keys per task) |
    | `task_options` | dict | `None` | the task's arguments (`target_speed`, `reward_weights`, `fall_lean`, ...) |
    | `render_mode` | str | `None` | `"human"` or `"rgb_array"` |

    ## Version History

    * v0: initial version.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "render_fps": 50}

    def __init__(self, render_mode: str | None = None, **kwargs):
        self.config = EnvConfig.from_kwargs(**kwargs)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": max(1, round(1 / self.config.dt))}
        self.task = self.config.task
        self.dt = self.config.dt
        self.action_space = self.config.action_space
        self.observation_space = self.config.observation_space
        self._step = scalar_step(self.config.integrator, FULL_MODEL)
        self._substeps = self.config.substeps
        self._substep = self.config.dt / self.config.substeps
        self._actuator_rows = self.config.actuator_rows
        self._actuator_limits = self.config.actuator_limits
        self._obs_bounds = (self.observation_space.low.tolist(), self.observation_space.high.tolist())
        self._renderer = None
        self._state: list[float] | None = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.params, self.goal, self._state = self.config.sample_episode(self.np_random, options)
        self._constants = self.params.constants
        self._error_sums = [0.0] if self.task.success_bound is not None else None
        self._track = None if self.render_mode is None else deque([(self._state[0], self._state[1])], TRACK_LENGTH)
        self._torque = (0.0, 0.0)
        self._elapsed = 0
        if self.render_mode == "human":
            self.render()
        return self._observation(), self._info({}, terminated=False)

    def step(self, action):
        if self._state is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        torque, effort = self._torques(action)
        args = (*torque, *self._constants)
        x = self._state
        try:
            for _ in range(self._substeps):
                x = self._step(x, self._substep, *args)
            in_domain = abs(x[3]) < LEAN_LIMIT and math.isfinite(sum(x))
        except (OverflowError, ZeroDivisionError):
            in_domain = False
        if in_domain:
            self._state = x
        else:
            x = self._state
        self._torque = torque
        self._elapsed += 1
        if self._track is not None:
            self._track.append((x[0], x[1]))
        terms = self.task.reward_terms(x, effort, self.goal, SCALAR_MATH)
        terminated = not in_domain or self.task.fallen(x, SCALAR_MATH)
        if self._error_sums is not None:
            self._error_sums.append(self._error_sums[-1] + self.task.tracking_error(x, self.goal, SCALAR_MATH))
        info = self._info(terms, terminated)
        if terminated:
            info["termination"] = "fallen" if in_domain else "out_of_domain"
        if self.render_mode == "human":
            self.render()
        return self._observation(), float(self.task.reward(terms)), terminated, False, info

    def _torques(self, action) -> tuple[tuple[float, float], float]:
        """Checks the action and clips it to [-1, 1]; returns (tau_spin, tau_steer) in N m and the effort term,
        the mean squared clipped action. Plain floats: this runs every step."""
        fast = type(action) is np.ndarray and action.dtype.kind in "fi" and action.shape == self.action_space.shape
        if not fast:
            error = action_error(action, self.action_space.shape)
            if error:
                raise ValueError(error)
            action = np.asarray(action)
        values = action.tolist()
        torque = [0.0, 0.0]
        effort = 0.0
        for value, row, limit in zip(values, self._actuator_rows, self._actuator_limits):
            if not math.isfinite(value):
                raise ValueError(f"action must be finite numbers, got {action!r}")
            value = -1.0 if value < -1.0 else (1.0 if value > 1.0 else value)
            torque[row] = limit * value
            effort += value * value
        return (torque[0], torque[1]), effort / len(values) if values else 0.0

    def _observation(self) -> np.ndarray:
        components = self.task.observe(self._state, self.goal, SCALAR_MATH)
        return np.array(
            [low if v < low else (high if v > high else v) for v, low, high in zip(components, *self._obs_bounds)],
            dtype=np.float32,
        )

    def _info(self, terms: dict, terminated: bool) -> dict:
        x = self._state
        if self._error_sums is None:
            success = not terminated
        else:
            steps = len(self._error_sums) - 1
            half = steps // 2
            mean_error = (self._error_sums[-1] - self._error_sums[half]) / max(1, steps - half)
            success = not terminated and mean_error <= self.task.success_bound
        energy, *contact_force = scalar.diagnostics(x, *self._torque, *self._constants)
        return {
            "state": np.array(x),
            "energy": energy,
            "contact_force": np.array(contact_force),
            "rewards": terms,
            "is_success": success,
        }

    def render(self):
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or 'human' to gymnasium.make"
            )
            return None
        if self._renderer is None:
            from rolling_disk_env.rendering import DiskRenderer

            self._renderer = DiskRenderer(self.render_mode, self.metadata["render_fps"])
        return self._renderer.draw(self._elapsed * self.dt, self._state, self.params, self.goal, self.task, self._track)

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
