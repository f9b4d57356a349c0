"""``task="circle"``: roll on a circle of a given radius about a given centre, at a target speed.

The feasible motion is the paper's steady circle (Case 3): for a centre-path radius R and speed v the disk turns at
``dpsi* = v / R``, leans ``theta*`` solving the circle condition, and spins at ``dphi* = v / r + dpsi* sin(theta*)``
(:func:`rolling_disk_env.dynamics.steady_circle`). The disk starts near the circle, tangent to it, but vertical and
rolling straight: above the self-stabilizing speed, a passive disk keeps rolling straight and leaves the circle. The
agent has to lean it into the turn, which it can only do through the gyroscopic coupling of the steer torque.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from rolling_disk_env import engine
from rolling_disk_env.dynamics import DiskParams, is_number, number_pair, steady_circle
from rolling_disk_env.engine import FALLEN, RUNNING
from rolling_disk_env.jit import inline_kernel, kernel
from rolling_disk_env.tasks.base import (
    C1,
    C2,
    COS_PSI,
    DPHI,
    DPSI,
    DTHETA,
    GRAVITY,
    RADIUS,
    SIN_PSI,
    THETA,
    TRACK,
    Task,
    circle_points,
    penalty,
)

# Positions in this task's arrays.
TARGET_SPEED, FALL_LEAN, CENTRE_X, CENTRE_Y = range(4)  # settings
CIRCLE_RADIUS, CIRCLE_X, CIRCLE_Y, TARGET_THETA, TARGET_DPHI, TARGET_DPSI = range(6)  # goal
(
    DRAWN_RADIUS,  # goal range
    DRAWN_ANGLE,
    DRAWN_RADIAL_OFFSET,
    DRAWN_HEADING_ERROR,
    DRAWN_THETA,
    DRAWN_DTHETA,
    DRAWN_DPHI_ERROR,
    DRAWN_DPSI,
    DRAWN_PHI,
) = range(9)


class CircleTask(Task):
    """Hold a counter-clockwise circle of radius R (randomized per episode) about ``centre`` at ``target_speed``.

    Observation (float32), with ``e_r = |c - centre| - R`` and heading error ``delta`` between the rolling direction
    ``(sin psi, -cos psi)`` and the circle's tangent: ``radial_error`` e_r (m, clipped to +-10), ``sin_heading_error``,
    ``cos_heading_error``, ``theta_error`` theta - theta* (rad), ``dtheta``, ``dphi_error`` dphi - dphi*,
    ``dpsi_error`` dpsi - dpsi* (rad/s), and ``target_lean`` theta* (rad), which tells the agent the episode's R.

    Reward terms (weights: ``reward_weights``):
        ``alive`` 1 every step; ``radial`` -min((e_r / 1 m)^2, 1); ``speed`` -min(((dphi - dphi*) / dphi*)^2, 1);
        ``effort`` minus the mean squared normalized action.

    Initial state (``initial_ranges``): at ``angle`` (rad) around the circle, ``radial_offset`` (m) off it, heading
    ``heading_error`` (rad) off its tangent; ``theta``, ``dtheta``, ``dpsi`` (rad, rad/s) near zero, ``dphi`` at
    ``dphi* (1 + dphi_error)``, ``phi`` (rad) anywhere.

    Success: not falling (|theta| > ``fall_lean`` = 0.8 rad) and an exponentially weighted mean of |e_r| over the
    episode, bias-corrected, of at most ``success_bound`` = 0.25 m: ``sum_n w^(N-n) |e_r(n)| / sum_n w^(N-n)`` after
    step N, with ``w = exp(-dt / tau)`` and the time constant ``tau`` = ``success_time_constant`` = 2.5 s (the error
    of a step t seconds ago weighs ``exp(-t / tau)`` against the latest's; over the 10 s of an episode, the first half
    weighs 13.5%). Two numbers a disk, kept as the episode goes, whatever its length (the single env does not know its
    limit: Gymnasium's TimeLimit truncates). 2.5 s is the mean age of the errors the rule it replaces averaged, the
    last half of a 10 s episode.

    Version History:
        * v0: success was the plain mean of |e_r| over the last half of the episode (each disk kept every step's
          error, ~4 KB a disk at 500 steps); now the exponentially weighted mean above, which needs no history. The
          episodes (observations, rewards, terminations) are unchanged; only ``info["is_success"]`` moves.
    """

    name = "circle"
    observation_names = (
        "radial_error",
        "sin_heading_error",
        "cos_heading_error",
        "theta_error",
        "dtheta",
        "dphi_error",
        "dpsi_error",
        "target_lean",
    )
    default_reward_weights: ClassVar[dict[str, float]] = {"alive": 1.0, "radial": 1.0, "speed": 0.3, "effort": 0.1}
    goal_names = ("radius", "cx", "cy", "theta", "dphi", "dpsi")
    setting_names = ("target_speed", "fall_lean", "centre_x", "centre_y")
    default_initial_ranges: ClassVar[dict[str, tuple[float, float]]] = {
        "angle": (-math.pi, math.pi),
        "radial_offset": (-0.5, 0.5),
        "heading_error": (-0.2, 0.2),
        "theta": (-0.05, 0.05),
        "dtheta": (-0.1, 0.1),
        "dphi_error": (-0.1, 0.1),
        "dpsi": (-0.1, 0.1),
        "phi": (-math.pi, math.pi),
    }
    fall_lean = 0.8
    success = TRACK
    success_bound = 0.25
    success_time_constant = 2.5
    radial_error_bound = 10.0

    def __init__(
        self,
        target_speed: float = 2.0,
        radius_range: tuple[float, float] = (3.0, 6.0),
        centre: tuple[float, float] = (0.0, 0.0),
        **kwargs,
    ):
        """
        Args:
            target_speed: speed of the disk's centre, m/s (default 2.0: dphi about 2 rad/s for the default disk,
                above the self-stabilizing 1.81 rad/s).
            radius_range: the circle's radius R is drawn uniformly from it each episode, m.
            centre: the circle's centre (x, y), m.
            **kwargs: ``reward_weights``, ``fall_lean`` (see :class:`Task`).
        """
        super().__init__(**kwargs)
        low, high = number_pair(radius_range, "radius_range")
        if not (is_number(target_speed) and math.isfinite(target_speed) and target_speed > 0):
            raise ValueError(f"target_speed must be a finite number > 0 (m/s), got {target_speed!r}")
        if not (math.isfinite(high) and 0 < low <= high):
            raise ValueError(f"radius_range must satisfy 0 < low <= high (m), got {radius_range!r}")
        self.target_speed = float(target_speed)
        self.radius_range = (low, high)
        self.centre_x, self.centre_y = number_pair(centre, "centre", "(x, y)")
        if not (math.isfinite(self.centre_x) and math.isfinite(self.centre_y)):
            raise ValueError(f"centre must be finite (m), got {centre!r}")

    mark_label = "target circle"

    def marks(self, goal: dict[str, float]) -> list[np.ndarray]:
        """The episode's circle."""
        return [circle_points(goal["cx"], goal["cy"], goal["radius"])]

    def check_disk(self, params: DiskParams) -> None:
        """Raises ``ValueError`` if the range's tightest circle has no steady motion for the disk ``params``."""
        steady_circle(self.radius_range[0], self.target_speed, params)

    def observation_bound(self, name: str) -> float:
        bounds = {
            "radial_error": self.radial_error_bound,
            "sin_heading_error": 1.0,
            "cos_heading_error": 1.0,
            "theta_error": math.pi,
            "target_lean": math.pi / 2,
        }
        return bounds.get(name, super().observation_bound(name))

    @property
    def goal_ranges(self) -> dict[str, tuple[float, float]]:
        return {"radius": self.radius_range}


@kernel
def start(drawn, disk, settings):
    """The episode's steady circle, and a vertical disk rolling straight near it, tangent to it."""
    radius = drawn[DRAWN_RADIUS]
    theta, dphi, dpsi = engine.steady_circle(radius, settings[TARGET_SPEED], disk[GRAVITY], disk[RADIUS])
    goal = (radius, settings[CENTRE_X], settings[CENTRE_Y], theta, dphi, dpsi)
    angle = drawn[DRAWN_ANGLE]
    distance = radius + drawn[DRAWN_RADIAL_OFFSET]
    # Rolling direction (sin psi, -cos psi) along the counter-clockwise tangent (-sin a, cos a): psi = a + pi.
    x = (
        goal[CIRCLE_X] + distance * math.cos(angle),
        goal[CIRCLE_Y] + distance * math.sin(angle),
        drawn[DRAWN_PHI],
        drawn[DRAWN_THETA],
        angle + math.pi + drawn[DRAWN_HEADING_ERROR],
        dphi * (1.0 + drawn[DRAWN_DPHI_ERROR]),
        drawn[DRAWN_DTHETA],
        drawn[DRAWN_DPSI],
    )
    return goal, x


@inline_kernel
def radial_error(x, goal):
    """|c - centre| - R (m)."""
    dx, dy = x[C1] - goal[CIRCLE_X], x[C2] - goal[CIRCLE_Y]
    return math.sqrt(dx * dx + dy * dy) - goal[CIRCLE_RADIUS]


@inline_kernel
def observe(x, trig, velocity, goal, settings):
    dx, dy = x[C1] - goal[CIRCLE_X], x[C2] - goal[CIRCLE_Y]
    distance = math.sqrt(dx * dx + dy * dy)
    sin_psi, cos_psi = trig[SIN_PSI], trig[COS_PSI]
    # delta = psi - angle - pi, with (cos angle, sin angle) = (dx, dy) / distance.
    scale = 1.0 / (distance + 1e-9)
    return (
        distance - goal[CIRCLE_RADIUS],
        (cos_psi * dy - sin_psi * dx) * scale,
        -(cos_psi * dx + sin_psi * dy) * scale,
        x[THETA] - goal[TARGET_THETA],
        x[DTHETA],
        x[DPHI] - goal[TARGET_DPHI],
        x[DPSI] - goal[TARGET_DPSI],
        goal[TARGET_THETA],
    )


@inline_kernel
def reward_terms(x, trig, velocity, code, effort, goal, settings):
    alive = 1.0
    radial = penalty(radial_error(x, goal))
    speed = penalty((x[DPHI] - goal[TARGET_DPHI]) / goal[TARGET_DPHI])
    return (alive, radial, speed, -effort)


@inline_kernel
def termination(x, goal, settings):
    return FALLEN if abs(x[THETA]) > settings[FALL_LEAN] else RUNNING


@inline_kernel
def tracking_error(x, goal, settings):
    return abs(radial_error(x, goal))
