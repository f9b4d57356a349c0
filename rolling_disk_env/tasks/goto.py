"""``task="goto"``: roll to a target point on the plane while staying up.

The disk reaches the plane's points only by rolling and turning: the steer torque turns the heading, and the lean
follows through the gyroscopic coupling (a steady turn needs the lean of the paper's steady circle). No continuous
time-invariant feedback stabilizes a nonholonomic system like this one to a point (Brockett's condition), and the
target here need not even be stopped at: the disk has to pass within ``reach_radius`` of it. A linear controller
about one operating point does not do that; the task's baseline (``agents/baselines.py``) switches between turning
and rolling straight.

The disk starts at the origin, near upright, rolling slowly in a random heading, below the self-stabilizing spin
rate sqrt(g / 3r) (1.81 rad/s for the default disk), so a passive disk falls; the target lies at a distance and a
bearing (relative to the initial rolling direction) drawn per episode.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from rolling_disk_env.dynamics import is_number, number_pair
from rolling_disk_env.engine import FALLEN, LIFTED_OFF, REACHED, RUNNING
from rolling_disk_env.jit import inline_kernel, kernel
from rolling_disk_env.tasks.base import (
    C1,
    C2,
    COS_PSI,
    DPHI,
    DPSI,
    DTHETA,
    RADIUS,
    REACH,
    SIN_PSI,
    THETA,
    Task,
    circle_points,
    penalty,
)

# Positions in this task's arrays.
CRUISE_SPEED, FALL_LEAN, REACH_RADIUS = range(3)  # settings
TARGET_X, TARGET_Y, TARGET_DPHI = range(3)  # goal
(
    DRAWN_DISTANCE,  # goal ranges
    DRAWN_BEARING,
    DRAWN_PHI,  # initial ranges
    DRAWN_PSI,
    DRAWN_THETA,
    DRAWN_DTHETA,
    DRAWN_DPHI,
    DRAWN_DPSI,
) = range(8)
AIM_SCALE = 1.0
"""m. The miss distance at which the ``aim`` penalty saturates."""


class GotoTask(Task):
    """Bring the centre's ground projection within ``reach_radius`` of a target point without falling.

    Observation (float32), with ``d`` the horizontal distance from the centre to the target and ``beta`` the target's
    bearing from the rolling direction ``(sin psi, -cos psi)``, positive to the left (counter-clockwise, the way a
    positive dpsi turns): ``distance`` d (m, clipped to 2.5 times the farthest target distance, 20 m by default),
    ``sin_bearing``, ``cos_bearing``, ``theta`` (rad), ``dtheta``, ``dphi_error`` dphi - dphi* and ``dpsi`` (rad/s),
    where ``dphi* = cruise_speed / r``.

    Reward terms (weights: ``reward_weights``), each in [-1, 1]:
        ``progress`` the centre's velocity towards the target over ``cruise_speed``, clipped to [-1, 1] (rolling
        straight at the target at cruise speed: +1; summed over an episode, about the distance covered towards the
        target over ``cruise_speed * dt``, 25 per metre by default); ``aim`` -min((miss / 1 m)^2, 1), where ``miss``
        is how far the disk would pass from the target if it rolled straight on, d |sin beta| with the target ahead,
        d with it behind; ``speed`` -min(((dphi - dphi*) / dphi*)^2, 1); ``upright`` -min((theta / fall_lean)^2, 1);
        ``effort`` minus the mean squared normalized action; ``reached`` +1 on the step the target is reached (the
        episode's last, ``Termination.REACHED``); ``fallen`` -1 on the step the episode ends by a fall or a lift-off
        (``Termination.FALLEN``, ``Termination.LIFTED_OFF``: the normal force vanishing). Default weights 1, 0.2, 0.3,
        0.5, 0.1, 100, 100.

    Why these terms: a success is worth its distance's progress plus 100 and a fall costs 100, so that ending an
    episode by falling, or by spinning the disk off the ground, never pays (without ``fallen`` on a lift-off, PPO
    learnt to end hopeless episodes so). ``progress`` alone rewards passing near the target as much as through it
    (cos beta is flat at beta = 0): ``aim`` makes the policy steer onto it (without it, PPO's policies kept passing
    beside targets). ``speed`` leads to the cruise speed, at which the disk stabilizes itself (without it, one PPO
    seed in three settled on spinning the disk about the vertical like a top instead).

    ``progress`` is ``dc/dt . u / cruise_speed``, ``u`` the unit vector from the centre to the target and ``dc/dt``
    the centre's velocity: rolling, ``r (dphi - dpsi sin theta) (sin psi, -cos psi) + r cos(theta) dtheta (cos psi,
    sin psi)`` (the rolling constraint), so ``progress`` reads ``r ((dphi - dpsi sin theta) cos beta + cos(theta)
    dtheta sin beta) / cruise_speed``; under the ``"sliding"`` and ``"coulomb"`` contacts, the sliding centre's own.

    Initial state: ``c1 = c2 = 0``; ``phi``, ``psi``, ``theta``, ``dtheta``, ``dphi``, ``dpsi`` uniform in
    ``initial_ranges`` (rad, rad/s; by default phi and psi in [-pi, pi], |theta| <= 0.05, dphi in [0.8, 1.2], below
    the self-stabilizing spin rate). Target: at a distance drawn from ``distance_range`` (default 3 to 8 m) and a
    bearing from the initial rolling direction drawn from ``bearing_range`` (default any, [-pi, pi] rad).
    ``reset(options={"state": x0})`` keeps the drawn target (it is placed from the drawn heading, not x0's).

    Success: the centre's ground projection comes within ``reach_radius`` = 0.25 m of the target without falling
    (|theta| > ``fall_lean`` = 0.8 rad); the episode then terminates (``info["termination"] == Termination.REACHED``).
    Failure: falling (or lifting off), or the time limit.
    """

    name = "goto"
    observation_names = ("distance", "sin_bearing", "cos_bearing", "theta", "dtheta", "dphi_error", "dpsi")
    default_reward_weights: ClassVar[dict[str, float]] = {
        "progress": 1.0,
        "aim": 0.2,
        "speed": 0.3,
        "upright": 0.5,
        "effort": 0.1,
        "reached": 100.0,
        "fallen": 100.0,
    }
    goal_names = ("x", "y", "dphi")
    setting_names = ("cruise_speed", "fall_lean", "reach_radius")
    default_initial_ranges: ClassVar[dict[str, tuple[float, float]]] = {
        "phi": (-math.pi, math.pi),
        "psi": (-math.pi, math.pi),
        "theta": (-0.05, 0.05),
        "dtheta": (-0.1, 0.1),
        "dphi": (0.8, 1.2),
        "dpsi": (-0.1, 0.1),
    }
    fall_lean = 0.8
    success = REACH

    def __init__(
        self,
        cruise_speed: float = 2.0,
        distance_range: tuple[float, float] = (3.0, 8.0),
        bearing_range: tuple[float, float] = (-math.pi, math.pi),
        reach_radius: float = 0.25,
        **kwargs,
    ):
        """
        Args:
            cruise_speed: the rolling speed the spin-rate error and the progress refer to, m/s (default 2.0:
                dphi* = 2 rad/s for the default disk, above the self-stabilizing 1.81 rad/s).
            distance_range: the target's initial distance from the centre is drawn uniformly from it, m; its low
                end must exceed ``reach_radius``.
            bearing_range: the target's bearing from the initial rolling direction is drawn uniformly from it, rad
                (positive: to the left).
            reach_radius: the target is reached when the centre's ground projection is this close, m.
            **kwargs: ``reward_weights``, ``fall_lean`` (see :class:`Task`).
        """
        super().__init__(**kwargs)
        if not (is_number(cruise_speed) and math.isfinite(cruise_speed) and cruise_speed > 0):
            raise ValueError(f"cruise_speed must be a finite number > 0 (m/s), got {cruise_speed!r}")
        if not (is_number(reach_radius) and math.isfinite(reach_radius) and reach_radius > 0):
            raise ValueError(f"reach_radius must be a finite number > 0 (m), got {reach_radius!r}")
        low, high = number_pair(distance_range, "distance_range")
        if not (math.isfinite(high) and reach_radius < low <= high):
            raise ValueError(
                f"distance_range must satisfy reach_radius ({reach_radius} m) < low <= high (m), got {distance_range!r}"
            )
        bearing_low, bearing_high = number_pair(bearing_range, "bearing_range")
        if not (math.isfinite(bearing_low) and math.isfinite(bearing_high) and bearing_low <= bearing_high):
            raise ValueError(f"bearing_range must be finite with low <= high (rad), got {bearing_range!r}")
        self.cruise_speed = float(cruise_speed)
        self.distance_range = (low, high)
        self.bearing_range = (bearing_low, bearing_high)
        self.reach_radius = float(reach_radius)
        self.success_bound = self.reach_radius

    def marks(self, goal: dict[str, float]) -> list[np.ndarray]:
        """The target, as the circle of ``reach_radius`` about it."""
        return [circle_points(goal["x"], goal["y"], self.reach_radius, 24)]

    def observation_bound(self, name: str) -> float:
        bounds = {
            "distance": 2.5 * self.distance_range[1],
            "sin_bearing": 1.0,
            "cos_bearing": 1.0,
            "theta": math.pi / 2,
        }
        return bounds.get(name, super().observation_bound(name))

    @property
    def goal_ranges(self) -> dict[str, tuple[float, float]]:
        return {"distance": self.distance_range, "bearing": self.bearing_range}


@kernel
def start(drawn, disk, settings):
    """At the origin, the angles and rates drawn; the target at the drawn distance and bearing from the rolling
    direction ``(sin psi, -cos psi)``, that is at the angle ``psi - pi/2 + bearing`` from the x axis."""
    phi, psi, theta = drawn[DRAWN_PHI], drawn[DRAWN_PSI], drawn[DRAWN_THETA]
    distance, direction = drawn[DRAWN_DISTANCE], psi - 0.5 * math.pi + drawn[DRAWN_BEARING]
    goal = (distance * math.cos(direction), distance * math.sin(direction), settings[CRUISE_SPEED] / disk[RADIUS])
    x = (0.0, 0.0, phi, theta, psi, drawn[DRAWN_DPHI], drawn[DRAWN_DTHETA], drawn[DRAWN_DPSI])
    return goal, x


@inline_kernel
def to_target(x, goal):
    """``(d, u1, u2)``: the centre's horizontal distance to the target (m) and the unit vector from the centre
    towards it (0 at the target)."""
    dx, dy = goal[TARGET_X] - x[C1], goal[TARGET_Y] - x[C2]
    distance = math.sqrt(dx * dx + dy * dy)
    scale = 1.0 / (distance + 1e-9)
    return distance, dx * scale, dy * scale


@inline_kernel
def bearing(trig, u1, u2):
    """``(sin beta, cos beta)``: the sine and cosine of the bearing of the unit vector ``(u1, u2)`` (towards the
    target, :func:`to_target`) from the rolling direction of a disk whose angles' sines and cosines are ``trig`` (both
    0 where ``u`` is)."""
    sin_psi, cos_psi = trig[SIN_PSI], trig[COS_PSI]
    # Rolling direction f = (sin psi, -cos psi): cos beta = f . u, sin beta = f x u.
    return sin_psi * u2 + cos_psi * u1, sin_psi * u1 - cos_psi * u2


@inline_kernel
def observe(x, trig, velocity, goal, settings):
    distance, u1, u2 = to_target(x, goal)
    sin_bearing, cos_bearing = bearing(trig, u1, u2)
    return (distance, sin_bearing, cos_bearing, x[THETA], x[DTHETA], x[DPHI] - goal[TARGET_DPHI], x[DPSI])


@inline_kernel
def reward_terms(x, trig, velocity, code, effort, goal, settings):
    distance, u1, u2 = to_target(x, goal)
    sin_bearing, cos_bearing = bearing(trig, u1, u2)
    theta = x[THETA]
    progress = min(max((velocity[0] * u1 + velocity[1] * u2) / settings[CRUISE_SPEED], -1.0), 1.0)
    # The miss distance if the disk rolled straight on: d |sin beta| ahead, d behind.
    miss = distance * abs(sin_bearing) if cos_bearing > 0.0 else distance
    aim = penalty(miss / AIM_SCALE)
    speed = penalty((x[DPHI] - goal[TARGET_DPHI]) / goal[TARGET_DPHI])
    upright = penalty(theta / settings[FALL_LEAN])
    # | rather than "or": both sides are evaluated, so no branch keeps the step's loop scalar.
    fallen = (code == FALLEN) | (code == LIFTED_OFF)
    return (progress, aim, speed, upright, -effort, 1.0 if code == REACHED else 0.0, -1.0 if fallen else 0.0)


@inline_kernel
def termination(x, goal, settings):
    if abs(x[THETA]) > settings[FALL_LEAN]:
        return FALLEN
    distance = to_target(x, goal)[0]
    return REACHED if distance <= settings[REACH_RADIUS] else RUNNING
