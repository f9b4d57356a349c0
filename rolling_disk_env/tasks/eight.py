"""``task="eight"``: ride a figure eight, whose curvature changes sign at every crossing, at a target speed.

The eight is the vehicle-testing figure: two circles of radius R that touch at the crossing point, the first (lobe A)
ridden counter-clockwise, the second (lobe B) clockwise, tangent to each other there, so the path's direction is
continuous and its curvature jumps from 1/R to -1/R. On each lobe the feasible motion is the paper's steady circle
(:func:`rolling_disk_env.dynamics.steady_circle`), leaning into the turn; at each crossing the disk has to swing its
lean over to the other side, through upright, which it can only do through the gyroscopic coupling of the steer
torque. The observation shows how far the crossing is, so that an agent can start the swing ahead of it.

Progress is counted in gates, four a lobe at every quarter turn (the last at the crossing): the task's progress
(:attr:`rolling_disk_env.tasks.Task.progress_names`) is the next gate, and a gate counts when the disk has turned past
it about the centre of its lobe. The radial error is taken to the circle of the next gate's lobe, so a disk that
rides one lobe again instead of crossing over drifts off the course and the episode ends (``Termination.OFF_COURSE``):
one full eight, eight gates in their order, is the success (``tests/test_eight.py``).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from rolling_disk_env import engine
from rolling_disk_env.dynamics import DiskParams, is_number, number_pair, steady_circle
from rolling_disk_env.engine import FALLEN, LIFTED_OFF, OFF_COURSE, REACHED, RUNNING
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
    REACH,
    SIN_PSI,
    THETA,
    Task,
    circle_points,
    penalty,
)

# Positions in this task's arrays.
TARGET_SPEED, FALL_LEAN, COURSE_BOUND = range(3)  # settings
CX, CY, NX, NY, LOBE_RADIUS, TARGET_THETA, TARGET_DPHI, TARGET_DPSI, GATE, PASSED, JUST_PASSED = range(11)  # goal
(
    DRAWN_RADIUS,  # goal ranges
    DRAWN_ORIENTATION,
    DRAWN_GATE,
    DRAWN_RADIAL_OFFSET,  # initial ranges
    DRAWN_HEADING_ERROR,
    DRAWN_THETA,
    DRAWN_DTHETA,
    DRAWN_DPHI_ERROR,
    DRAWN_DPSI,
    DRAWN_PHI,
) = range(10)
GATES = 8
"""Gates of one eight: four a lobe, at each quarter turn about its centre."""


class EightTask(Task):
    """Ride a figure eight of two circles of radius R (randomized per episode) at ``target_speed``, within
    ``course_bound`` of the path, for one whole eight.

    With the next gate on lobe A (gates 0 to 3: centre ``c + R n``, counter-clockwise, ``s = +1``) or lobe B (gates 4
    to 7: centre ``c - R n``, clockwise, ``s = -1``), ``c`` the crossing point and ``n`` a unit vector drawn per
    episode: observation (float32) ``radial_error`` e_r = |p - centre| - R (m, clipped to +-10) of the centre's ground
    point p, ``sin_heading_error``, ``cos_heading_error`` of the rolling direction ``(sin psi, -cos psi)`` from the
    lobe's direction of travel, ``theta_error`` theta - s theta* (rad), ``dtheta``, ``dphi_error`` dphi - dphi*,
    ``dpsi_error`` dpsi - s dpsi* (rad/s), ``target_lean`` s theta* (rad: its sign tells the lobe), ``gate_sin`` and
    ``gate_cos``, the sine and cosine of the angle the disk has still to turn about the lobe's centre to the next
    gate, and ``quarters_left``, the gates left on the lobe after the next (3, 2, 1, 0) over 3: 0 on the quarter that
    ends at the crossing. ``(theta*, dphi*, dpsi*)`` is the steady circle of radius R at the target speed.

    Reward terms (weights: ``reward_weights``), each in [-1, 1]: ``progress`` the centre's velocity along the lobe's
    direction of travel over ``target_speed``, clipped; ``radial`` -min((e_r / 1 m)^2, 1); ``speed``
    -min(((dphi - dphi*) / dphi*)^2, 1); ``effort`` minus the mean squared normalized action; ``gate`` +1 on the step
    a gate counts; ``reached`` +1 on the step the eighth does (``Termination.REACHED``, the episode's last);
    ``fallen`` -1 on the step the episode ends by a fall, a lift-off or straying off the course
    (``Termination.OFF_COURSE``). Default weights 1, 1, 0.3, 0.1, 10, 100, 100.

    Initial state (``initial_ranges``): at the gate before a gate drawn from the eight (``start_gate``),
    ``radial_offset`` (m) off the circle, heading ``heading_error`` (rad) off its direction of travel; ``theta``,
    ``dtheta``, ``dpsi`` (rad, rad/s) near zero: upright and rolling straight; ``dphi`` at ``dphi* (1 + dphi_error)``,
    ``phi`` (rad) anywhere. R drawn from ``radius_range`` (default 2.5 to 3.5 m), the eight's direction ``n`` from
    any angle, the crossing point at the origin.

    Success: eight gates in their order, one whole eight (``4 pi R`` of arc, 12.6 to 17.6 s at the default 2.5 m/s),
    without falling (|theta| > ``fall_lean`` = 0.8 rad) or straying past ``course_bound`` (1 m) of the next gate's
    circle; the episode then terminates (``Termination.REACHED``). Episodes of 1250 control periods (25 s) on the
    task's id.
    """

    name = "eight"
    observation_names = (
        "radial_error",
        "sin_heading_error",
        "cos_heading_error",
        "theta_error",
        "dtheta",
        "dphi_error",
        "dpsi_error",
        "target_lean",
        "gate_sin",
        "gate_cos",
        "quarters_left",
    )
    default_reward_weights: ClassVar[dict[str, float]] = {
        "progress": 1.0,
        "radial": 1.0,
        "speed": 0.3,
        "effort": 0.1,
        "gate": 10.0,
        "reached": 100.0,
        "fallen": 100.0,
    }
    goal_names = ("cx", "cy", "nx", "ny", "radius", "theta", "dphi", "dpsi")
    progress_names = ("gate", "passed", "just_passed")
    setting_names = ("target_speed", "fall_lean", "course_bound")
    default_initial_ranges: ClassVar[dict[str, tuple[float, float]]] = {
        "radial_offset": (-0.3, 0.3),
        "heading_error": (-0.1, 0.1),
        "theta": (-0.05, 0.05),
        "dtheta": (-0.1, 0.1),
        "dphi_error": (-0.05, 0.05),
        "dpsi": (-0.1, 0.1),
        "phi": (-math.pi, math.pi),
    }
    fall_lean = 0.8
    success = REACH

    def __init__(
        self,
        target_speed: float = 2.5,
        radius_range: tuple[float, float] = (2.5, 3.5),
        course_bound: float = 1.0,
        **kwargs,
    ):
        """
        Args:
            target_speed: speed of the disk's centre, m/s.
            radius_range: the lobes' radius R is drawn uniformly from it each episode, m.
            course_bound: m. The largest |radial error| before the episode ends off the course; below R.
            **kwargs: ``reward_weights``, ``fall_lean`` (see :class:`Task`).
        """
        super().__init__(**kwargs)
        low, high = number_pair(radius_range, "radius_range")
        if not (is_number(target_speed) and math.isfinite(target_speed) and target_speed > 0):
            raise ValueError(f"target_speed must be a finite number > 0 (m/s), got {target_speed!r}")
        if not (math.isfinite(high) and 0 < low <= high):
            raise ValueError(f"radius_range must satisfy 0 < low <= high (m), got {radius_range!r}")
        if not (is_number(course_bound) and 0 < course_bound < low):
            raise ValueError(
                f"course_bound must be a number in (0, radius_range's low = {low}) m, got {course_bound!r}"
            )
        self.target_speed = float(target_speed)
        self.radius_range = (low, high)
        self.course_bound = float(course_bound)

    mark_label = "the eight"

    def marks(self, goal: dict[str, float]) -> list[np.ndarray]:
        """The eight's two lobes."""
        radius, nx, ny = goal["radius"], goal["nx"], goal["ny"]
        return [circle_points(goal["cx"] + s * radius * nx, goal["cy"] + s * radius * ny, radius) for s in (1, -1)]

    def check_disk(self, params: DiskParams) -> None:
        """Raises ``ValueError`` if the range's tightest lobe has no steady motion for the disk ``params``."""
        steady_circle(self.radius_range[0], self.target_speed, params)

    def observation_bound(self, name: str) -> float:
        bounds = {"radial_error": 10.0, "theta_error": math.pi, "target_lean": math.pi / 2}
        if name in bounds:
            return bounds[name]
        return 1.0 if name.startswith(("sin", "cos", "gate", "quarters")) else super().observation_bound(name)

    @property
    def goal_ranges(self) -> dict[str, tuple[float, float]]:
        return {"radius": self.radius_range, "orientation": (-math.pi, math.pi), "start_gate": (0.0, float(GATES))}


@inline_kernel
def lobe(goal, gate):
    """``(s, cx, cy, ux, uy)`` of the gate numbered ``gate`` (0 to 7): the sense of its lobe (+1 counter-clockwise,
    -1 clockwise), its lobe's centre (m) and the unit vector from there to the gate."""
    s = 1.0 if gate < 3.5 else -1.0
    quarter = gate if gate < 3.5 else gate - 4.0
    nx, ny = goal[NX], goal[NY]
    radius = goal[LOBE_RADIUS]
    ux = ny if quarter < 0.5 else (s * nx if quarter < 1.5 else (-ny if quarter < 2.5 else -s * nx))
    uy = -nx if quarter < 0.5 else (s * ny if quarter < 1.5 else (nx if quarter < 2.5 else -s * ny))
    return s, goal[CX] + s * radius * nx, goal[CY] + s * radius * ny, ux, uy


@inline_kernel
def on_lobe(x, goal):
    """The disk against the next gate's lobe: ``(s, e_r, rx, ry, ux, uy, tx, ty)``, the lobe's sense, the radial
    error (m), the unit vector from the lobe's centre to the disk, to the next gate, and the direction of travel at
    the disk."""
    s, cx, cy, ux, uy = lobe(goal, goal[GATE])
    dx, dy = x[C1] - cx, x[C2] - cy
    distance = math.sqrt(dx * dx + dy * dy)
    scale = 1.0 / (distance + 1e-9)
    rx, ry = dx * scale, dy * scale
    return s, distance - goal[LOBE_RADIUS], rx, ry, ux, uy, -s * ry, s * rx


@kernel
def start(drawn, disk, settings):
    """The episode's eight (crossing at the origin) and a disk at the gate before the drawn one, upright, rolling
    straight along the lobe's direction of travel."""
    radius = drawn[DRAWN_RADIUS]
    theta, dphi, dpsi = engine.steady_circle(radius, settings[TARGET_SPEED], disk[GRAVITY], disk[RADIUS])
    orientation = drawn[DRAWN_ORIENTATION]
    gate = min(math.floor(drawn[DRAWN_GATE]), GATES - 1.0)
    targets = (0.0, 0.0, math.cos(orientation), math.sin(orientation), radius, theta, dphi, dpsi)
    s, cx, cy, ux, uy = lobe(targets, gate)
    # The gate before, a quarter turn back about the same centre: s (uy, -ux).
    px, py = s * uy, -s * ux
    distance = radius + drawn[DRAWN_RADIAL_OFFSET]
    tx, ty = -s * py, s * px  # the direction of travel there: (sin psi, -cos psi)
    psi = math.atan2(tx, -ty) + drawn[DRAWN_HEADING_ERROR]
    x = (
        cx + distance * px,
        cy + distance * py,
        drawn[DRAWN_PHI],
        drawn[DRAWN_THETA],
        psi,
        dphi * (1.0 + drawn[DRAWN_DPHI_ERROR]),
        drawn[DRAWN_DTHETA],
        drawn[DRAWN_DPSI],
    )
    return (*targets, gate, 0.0, 0.0), x


@inline_kernel
def advance(x, trig, velocity, goal, settings):
    s, _, rx, ry, ux, uy, _, _ = on_lobe(x, goal)
    # Turned past the gate: on its far side, within a quarter turn.
    passed = (s * (ux * ry - uy * rx) >= 0.0) & (ux * rx + uy * ry > 0.0)
    gate = goal[GATE] + 1.0 if passed else goal[GATE]
    return (
        gate - GATES if gate >= GATES else gate,
        goal[PASSED] + 1.0 if passed else goal[PASSED],
        1.0 if passed else 0.0,
    )


@inline_kernel
def observe(x, trig, velocity, goal, settings):
    s, radial, rx, ry, ux, uy, tx, ty = on_lobe(x, goal)
    forward_x, forward_y = trig[SIN_PSI], -trig[COS_PSI]
    quarter = goal[GATE] if goal[GATE] < 3.5 else goal[GATE] - 4.0
    return (
        radial,
        tx * forward_y - ty * forward_x,
        tx * forward_x + ty * forward_y,
        x[THETA] - s * goal[TARGET_THETA],
        x[DTHETA],
        x[DPHI] - goal[TARGET_DPHI],
        x[DPSI] - s * goal[TARGET_DPSI],
        s * goal[TARGET_THETA],
        s * (rx * uy - ry * ux),
        rx * ux + ry * uy,
        (3.0 - quarter) / 3.0,
    )


@inline_kernel
def reward_terms(x, trig, velocity, code, effort, goal, settings):
    _, radial, _, _, _, _, tx, ty = on_lobe(x, goal)
    progress = min(max((velocity[0] * tx + velocity[1] * ty) / settings[TARGET_SPEED], -1.0), 1.0)
    speed = penalty((x[DPHI] - goal[TARGET_DPHI]) / goal[TARGET_DPHI])
    fallen = (code == FALLEN) | (code == LIFTED_OFF) | (code == OFF_COURSE)
    reached = 1.0 if code == REACHED else 0.0
    return (progress, penalty(radial), speed, -effort, goal[JUST_PASSED], reached, -1.0 if fallen else 0.0)


@inline_kernel
def termination(x, goal, settings):
    if abs(x[THETA]) > settings[FALL_LEAN]:
        return FALLEN
    radial = on_lobe(x, goal)[1]
    if abs(radial) > settings[COURSE_BOUND]:
        return OFF_COURSE
    return REACHED if goal[PASSED] >= GATES else RUNNING
