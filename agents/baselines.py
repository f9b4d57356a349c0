"""Classical controllers for RollingDisk-v0, with the interface of a trained SB3 policy (``predict(obs)``).

* :class:`UprightLQR`: a discrete LQR on the lean model linearized about upright rolling at the task's target spin
  rate, from the SymPy Jacobians of f and B (``rolling_disk_env.dynamics.lean_jacobians``).
* :class:`CircleLQR`: the paper's steady circle as the operating point (feedforward: lean, spin and heading rates
  from the circle condition, zero torque) plus LQR feedback on the lean error and the radial and heading errors.
* :class:`GotoLQR`: a steady turn towards the target (the steady circle of a heading rate proportional to the
  target's bearing, saturated), straight rolling once aligned, with an LQR on the lean model scheduled over the turn.

All take the same observation and give the same normalized action in [-1, 1] as a policy, so the same evaluation
code runs every agent.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm, solve_discrete_are

from rolling_disk_env.dynamics import lean_jacobians, steady_circle
from rolling_disk_env.envs.config import ACTUATORS, EnvConfig


def discrete_lqr(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, dt: float) -> np.ndarray:
    """The gain ``K`` (u = -K x) of the infinite-horizon LQR of ``dx/dt = A x + B u`` held constant over ``dt``."""
    n, m = b.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = a, b
    discrete = expm(block * dt)
    ad, bd = discrete[:n, :n], discrete[:n, n:]
    p = solve_discrete_are(ad, bd, q, r)
    return np.linalg.solve(r + bd.T @ p @ bd, bd.T @ p @ ad)


class _Controller:
    """What the controllers share: the env's settings and SB3's ``predict``."""

    def __init__(self, **env_kwargs):
        self.config = EnvConfig.from_kwargs(**env_kwargs)
        missing = set(ACTUATORS) - set(self.config.actuators)
        if missing:
            raise ValueError(f"{type(self).__name__} needs both actuators, missing {sorted(missing)}")
        self.params = self.config.params
        self.torque_limits = np.array(self.config.max_torque)

    def action(self, observation: np.ndarray) -> np.ndarray:
        """Normalized action (spin, steer) in [-1, 1] for one observation."""
        raise NotImplementedError

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """SB3's signature: one observation or a batch, returns ``(actions, None)``."""
        observation = np.asarray(observation, dtype=np.float64)
        if observation.ndim == 1:
            return self.action(observation).astype(np.float32), None
        return np.array([self.action(o) for o in observation], dtype=np.float32), None


class UprightLQR(_Controller):
    """LQR about upright rolling at ``dphi*``: error ``(theta, dphi - dphi*, dtheta, dpsi)``, from the observation
    ``(theta, dtheta, dphi - dphi*, dpsi)``; weights by Bryson's rule on the given scales."""

    def __init__(self, lean_scale=0.05, spin_scale=0.5, rate_scale=0.5, heading_scale=0.5, **env_kwargs):
        super().__init__(**env_kwargs)
        if self.config.task.name != "upright":
            raise ValueError("UprightLQR is for task='upright'")
        dphi = self.config.task.target_spin_rate(self.params.radius)
        a, b = lean_jacobians((0.0, dphi, 0.0, 0.0), params=self.params)
        q = np.diag(1 / np.array([lean_scale, spin_scale, rate_scale, heading_scale]) ** 2)
        self.gain = discrete_lqr(a, b * self.torque_limits, q, np.eye(2), self.config.dt)

    def action(self, observation):
        theta, dtheta, dphi_error, dpsi = observation
        return np.clip(-self.gain @ np.array([theta, dphi_error, dtheta, dpsi]), -1.0, 1.0)


class CircleLQR(_Controller):
    """Steady circle plus LQR feedback.

    Error state ``(e_r, delta, theta - theta*, dphi - dphi*, dtheta, dpsi - dpsi*)``, e_r the radial error and delta
    the heading error to the tangent. Linearized, ``de_r/dt = -v delta`` (the disk rolls along the tangent turned
    by delta) and ``d delta/dt = (dpsi - dpsi*) + dpsi* e_r / R`` (a wider circle turns slower); the lean rows are
    the lean model's Jacobians at the steady circle. The gain is designed for the circle of the episode, which the
    observation gives through theta*; gains are cached by radius.
    """

    TASK = "circle"

    def __init__(
        self, radial_scale=0.3, heading_scale=0.3, lean_scale=0.1, spin_scale=1.0, rate_scale=1.0, **env_kwargs
    ):
        super().__init__(**env_kwargs)
        task = self.config.task
        if task.name != self.TASK:
            raise ValueError(f"{type(self).__name__} is for task={self.TASK!r}")
        self.speed = task.target_speed
        self.q = np.diag(
            1 / np.array([radial_scale, heading_scale, lean_scale, spin_scale, rate_scale, rate_scale]) ** 2
        )
        low, high = task.radius_range
        self.radii = np.linspace(low, high, 31)
        self.leans = np.array([steady_circle(radius, self.speed, self.params)[0] for radius in self.radii])
        self.gains = {}

    def _gain(self, radius: float) -> np.ndarray:
        key = round(radius, 3)
        if key not in self.gains:
            theta, dphi, dpsi = steady_circle(radius, self.speed, self.params)
            a_lean, b_lean = lean_jacobians((theta, dphi, 0.0, dpsi), params=self.params)
            a = np.zeros((6, 6))
            b = np.zeros((6, 2))
            a[0, 1] = -self.speed
            a[1, 5], a[1, 0] = 1.0, dpsi / radius
            a[2:, 2:], b[2:] = a_lean, b_lean
            self.gains[key] = discrete_lqr(a, b * self.torque_limits, self.q, np.eye(2), self.config.dt)
        return self.gains[key]

    def action(self, observation):
        radial, sin_delta, cos_delta, theta_error, dtheta, dphi_error, dpsi_error, target_lean = observation
        radius = float(np.interp(target_lean, self.leans, self.radii))
        error = np.array([radial, math.atan2(sin_delta, cos_delta), theta_error, dphi_error, dtheta, dpsi_error])
        return np.clip(-self._gain(radius) @ error, -1.0, 1.0)


class GotoLQR(_Controller):
    """Turn towards the target on a steady circle, roll straight once aligned; an LQR holds the lean.

    The target's bearing beta (from the observation's sine and cosine) sets the heading rate to command,
    ``dpsi_ref = heading_gain * beta`` saturated at ``cruise_speed / min_turn_radius``: a steady turn while the target
    is off the rolling direction, straight rolling once it is ahead. The operating point of that heading rate at the
    cruise speed is the paper's steady circle of radius ``cruise_speed / |dpsi_ref|`` (lean, spin and heading rates
    from :func:`rolling_disk_env.dynamics.steady_circle`, mirrored for a right turn; upright rolling for
    ``dpsi_ref = 0``), and an LQR on the lean model linearized there (:func:`rolling_disk_env.dynamics.lean_jacobians`)
    feeds the errors of ``(theta, dphi, dtheta, dpsi)`` back to both torques. Gains are scheduled over 41 heading
    rates; the nearest is used. The defaults were tuned on seeds 0 to 199 (evaluations use seeds from 10000).

    It cannot turn tighter than ``min_turn_radius``, so a target inside the turning circle beside the disk is
    circled around rather than reached (short distances at bearings near +-pi/2 fail). The same controller drives
    ``waypoints`` (towards the next waypoint) and ``ice`` (it does not know the contact slides): the tasks whose
    observation holds the next target's bearing, the lean and the rates under ``goto``'s names.
    """

    TASKS = ("goto", "waypoints", "ice")
    """The tasks whose observation it reads."""
    READS = ("sin_bearing", "cos_bearing", "theta", "dtheta", "dphi_error", "dpsi")
    """The observation's components it reads, by name."""

    def __init__(
        self,
        heading_gain=1.5,
        min_turn_radius=1.75,
        lean_scale=0.05,
        spin_scale=0.5,
        rate_scale=0.5,
        heading_scale=0.2,
        **env_kwargs,
    ):
        super().__init__(**env_kwargs)
        task = self.config.task
        if task.name not in self.TASKS:
            raise ValueError(f"GotoLQR is for the tasks {self.TASKS}, got {task.name!r}")
        self.reads = [task.observation_names.index(name) for name in self.READS]
        speed = task.cruise_speed
        self.heading_gain = heading_gain
        self.cruise_dphi = speed / self.params.radius
        max_rate = speed / min_turn_radius
        self.rates = np.linspace(-max_rate, max_rate, 41)
        q = np.diag(1 / np.array([lean_scale, spin_scale, rate_scale, heading_scale]) ** 2)
        self.references, self.gains = [], []
        for rate in self.rates:
            if rate == 0.0:
                reference = np.array([0.0, self.cruise_dphi, 0.0, 0.0])
            else:
                theta, dphi, dpsi = steady_circle(speed / abs(rate), speed, self.params)
                reference = np.array([math.copysign(theta, rate), dphi, 0.0, math.copysign(dpsi, rate)])
            a, b = lean_jacobians(reference, params=self.params)
            self.references.append(reference)
            self.gains.append(discrete_lqr(a, b * self.torque_limits, q, np.eye(2), self.config.dt))

    def action(self, observation):
        sin_bearing, cos_bearing, theta, dtheta, dphi_error, dpsi = observation[self.reads]
        rate = self.heading_gain * math.atan2(sin_bearing, cos_bearing)
        k = int(np.argmin(np.abs(self.rates - rate)))
        error = np.array([theta, dphi_error + self.cruise_dphi, dtheta, dpsi]) - self.references[k]
        return np.clip(-self.gains[k] @ error, -1.0, 1.0)


class EightLQR(CircleLQR):
    """:class:`CircleLQR` on the figure eight's lobe of the next gate, mirrored on the clockwise lobe, its steady
    circle eased out before each crossing and in after it.

    A reflection of the plane maps the clockwise lobe onto a counter-clockwise circle: the radial error and the
    spin rate stay, the heading error, the lean, the lean rate and the heading rate change sign, and so does the steer
    torque. The sign of the observation's target lean tells the lobe; the gain is the circle's of the episode's
    radius (from the target lean's size). Within ``ease`` rad of turn about the lobe's centre before a crossing and
    after it, the operating point's lean and heading rate are the steady circle's scaled by the turn's distance to
    the crossing over ``ease``: upright rolling at the crossing, so that the lean swings over there instead of being
    asked to jump (without it the controller fell at the first crossing in every episode).
    """

    TASK = "eight"

    def __init__(self, ease=0.8, **kwargs):
        super().__init__(**kwargs)
        self.ease = ease

    def action(self, observation):
        radial, sin_delta, cos_delta, theta_error, dtheta, dphi_error, dpsi_error, target_lean = observation[:8]
        gate_sin, gate_cos, quarters_left = observation[8:11]
        side = 1.0 if target_lean >= 0 else -1.0
        # The turn (rad) to the crossing ahead (the next gate is the crossing) or from the one behind (the next gate
        # is the lobe's first, a quarter turn after it).
        to_gate = math.atan2(gate_sin, gate_cos)
        from_crossing = (
            to_gate if quarters_left < 1 / 6 else (math.pi / 2 - to_gate if quarters_left > 5 / 6 else math.inf)
        )
        scale = min(max(from_crossing / self.ease, 0.0), 1.0)
        radius = float(np.interp(abs(target_lean), self.leans, self.radii))
        dpsi_target = self.speed / radius
        theta_error += (1.0 - scale) * target_lean
        dpsi_error += (1.0 - scale) * side * dpsi_target
        mirrored = np.array(
            [radial, side * sin_delta, cos_delta, side * theta_error, side * dtheta, dphi_error, side * dpsi_error]
        )
        action = np.clip(-self._gain(radius) @ self._error(mirrored), -1.0, 1.0)
        action[1] *= side
        return action

    @staticmethod
    def _error(mirrored):
        radial, sin_delta, cos_delta, theta_error, dtheta, dphi_error, dpsi_error = mirrored
        return np.array([radial, math.atan2(sin_delta, cos_delta), theta_error, dphi_error, dtheta, dpsi_error])


class RecoveryLQR(_Controller):
    """The LQR about upright rolling at the task's target spin rate: the lean model linearized at ``(0, dphi*, 0, 0)``
    (:func:`rolling_disk_env.dynamics.lean_jacobians`), error ``(theta, dphi - dphi*, dtheta, dpsi)``, with gains
    scheduled over the spin rate (the nearest of ``spins`` from ``dphi*`` up to ``max_spin``) where ``scheduled``:
    what linear control about the target does from the task's large leans and fast spins."""

    def __init__(
        self, lean_scale=0.1, spin_scale=1.0, rate_scale=0.5, heading_scale=0.5, scheduled=False, max_spin=30.0,
        **env_kwargs,
    ):  # fmt: skip
        super().__init__(**env_kwargs)
        task = self.config.task
        if task.name not in ("recovery", "recovery_sparse"):
            raise ValueError(f"RecoveryLQR is for the tasks recovery and recovery_sparse, got {task.name!r}")
        self.target = task.target_speed / self.params.radius
        self.spins = np.linspace(self.target, max_spin, 57) if scheduled else np.array([self.target])
        q = np.diag(1 / np.array([lean_scale, spin_scale, rate_scale, heading_scale]) ** 2)
        self.gains = []
        for dphi in self.spins:
            a, b = lean_jacobians((0.0, dphi, 0.0, 0.0), params=self.params)
            self.gains.append(discrete_lqr(a, b * self.torque_limits, q, np.eye(2), self.config.dt))

    def action(self, observation):
        theta, dtheta, dphi_error, dpsi, _ = observation
        k = int(np.argmin(np.abs(self.spins - abs(dphi_error + self.target))))
        return np.clip(-self.gains[k] @ np.array([theta, dphi_error, dtheta, dpsi]), -1.0, 1.0)


BASELINES = {
    "upright": UprightLQR,
    "circle": CircleLQR,
    "goto": GotoLQR,
    "waypoints": GotoLQR,
    "eight": EightLQR,
    "recovery": RecoveryLQR,
    "recovery_sparse": RecoveryLQR,
    "ice": GotoLQR,
}
"""The classical baseline of each task."""
