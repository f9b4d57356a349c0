"""``task="waypoints"``: roll through four waypoints in their order, over a long episode.

``goto`` four times in a row, without stopping: the disk has to pass within ``reach_radius`` of each waypoint in turn,
and only the next one counts: passing another first changes nothing (``tests/test_waypoints.py``). The next
waypoint, and the one after it, are in the observation, so that the agent can turn early towards the one after. The
task's progress (:attr:`rolling_disk_env.tasks.Task.progress_names`) is the index of the next waypoint, advanced by
the step where the disk passes it.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from rolling_disk_env.dynamics import is_number, number_pair
from rolling_disk_env.engine import FALLEN, LIFTED_OFF, REACHED, RUNNING
from rolling_disk_env.jit import inline_kernel, kernel
from rolling_disk_env.tasks.base import C1, C2, DPHI, DPSI, DTHETA, RADIUS, REACH, THETA, Task, circle_points, penalty
from rolling_disk_env.tasks.goto import AIM_SCALE, bearing

# Positions in this task's arrays.
CRUISE_SPEED, FALL_LEAN, REACH_RADIUS = range(3)  # settings
WAYPOINTS = 4
"""Waypoints of an episode."""
X0, Y0, X1, Y1, X2, Y2, X3, Y3, TARGET_DPHI, NEXT, PASSED = range(11)  # goal: targets, then progress
DRAWN_DISTANCE, DRAWN_TURN = 0, WAYPOINTS  # goal ranges: the legs' distances, then their turns
DRAWN_PHI, DRAWN_PSI, DRAWN_THETA, DRAWN_DTHETA, DRAWN_DPHI, DRAWN_DPSI = range(2 * WAYPOINTS, 2 * WAYPOINTS + 6)


class WaypointsTask(Task):
    """Pass within ``reach_radius`` of four waypoints, in order, without falling.

    Observation (float32), with the bearings measured from the rolling direction ``(sin psi, -cos psi)``, positive to
    the left: ``distance`` to the next waypoint (m, clipped to 2.5 times the longest leg, 15 m by default),
    ``sin_bearing``, ``cos_bearing`` of it, ``after_distance``, ``after_sin_bearing``, ``after_cos_bearing`` of the
    waypoint after it (the next one again when it is the last), ``theta`` (rad), ``dtheta``, ``dphi_error`` dphi - dphi*
    and ``dpsi`` (rad/s), where ``dphi* = cruise_speed / r``, and ``remaining``, the fraction of the waypoints still
    ahead (1 at the start).

    Reward terms (weights: ``reward_weights``), each in [-1, 1]: ``progress``, ``aim``, ``speed``, ``upright`` and
    ``effort`` as ``goto``'s (:class:`rolling_disk_env.tasks.goto.GotoTask`), towards the next waypoint; ``waypoint``
    +1 on the step a waypoint is passed; ``reached`` +1 on the step the last one is (the episode's last,
    ``Termination.REACHED``); ``fallen`` -1 on the step the disk falls or lifts off. Default weights 1, 0.2, 0.3, 0.5,
    0.1, 20, 100, 100.

    Initial state: ``c1 = c2 = 0``; ``phi``, ``psi``, ``theta``, ``dtheta``, ``dphi``, ``dpsi`` uniform in
    ``initial_ranges`` (as ``goto``'s: near upright, rolling at 0.8 to 1.2 rad/s, below the self-stabilizing spin
    rate). Waypoints: each a leg of a length drawn from ``leg_range`` (default 3 to 6 m) from the one before (the first
    from the start), turned from the leg before (the first from the initial rolling direction) by an angle drawn from
    ``turn_range`` (default -2 to 2 rad: no leg doubles straight back; the first's turn, as ``goto``'s bearing, from
    [-pi, pi]).

    Success: the last waypoint passed in order without falling (|theta| > ``fall_lean`` = 0.8 rad); the episode then
    terminates (``Termination.REACHED``). Episodes of 1000 control periods (20 s) on the task's id.
    """

    name = "waypoints"
    observation_names = (
        "distance",
        "sin_bearing",
        "cos_bearing",
        "after_distance",
        "after_sin_bearing",
        "after_cos_bearing",
        "theta",
        "dtheta",
        "dphi_error",
        "dpsi",
        "remaining",
    )
    default_reward_weights: ClassVar[dict[str, float]] = {
        "progress": 1.0,
        "aim": 0.2,
        "speed": 0.3,
        "upright": 0.5,
        "effort": 0.1,
        "waypoint": 20.0,
        "reached": 100.0,
        "fallen": 100.0,
    }
    goal_names = ("x0", "y0", "x1", "y1", "x2", "y2", "x3", "y3", "dphi")
    progress_names = ("next", "passed")
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
        leg_range: tuple[float, float] = (3.0, 6.0),
        turn_range: tuple[float, float] = (-2.0, 2.0),
        reach_radius: float = 0.25,
        **kwargs,
    ):
        """
        Args:
            cruise_speed: the rolling speed the spin-rate error and the progress refer to, m/s.
            leg_range: each waypoint's distance from the one before (the first's from the start) is drawn uniformly
                from it, m; its low end must exceed ``2 reach_radius``.
            turn_range: each leg's turn from the leg before is drawn uniformly from it, rad (positive: to the left).
            reach_radius: a waypoint is passed when the centre's ground projection is this close, m.
            **kwargs: ``reward_weights``, ``fall_lean`` (see :class:`Task`).
        """
        super().__init__(**kwargs)
        if not (is_number(cruise_speed) and math.isfinite(cruise_speed) and cruise_speed > 0):
            raise ValueError(f"cruise_speed must be a finite number > 0 (m/s), got {cruise_speed!r}")
        if not (is_number(reach_radius) and math.isfinite(reach_radius) and reach_radius > 0):
            raise ValueError(f"reach_radius must be a finite number > 0 (m), got {reach_radius!r}")
        low, high = number_pair(leg_range, "leg_range")
        if not (math.isfinite(high) and 2 * reach_radius < low <= high):
            raise ValueError(
                f"leg_range must satisfy 2 reach_radius ({2 * reach_radius} m) < low <= high (m), got {leg_range!r}"
            )
        turn_low, turn_high = number_pair(turn_range, "turn_range")
        if not (-math.pi <= turn_low <= turn_high <= math.pi):
            raise ValueError(f"turn_range must satisfy -pi <= low <= high <= pi (rad), got {turn_range!r}")
        self.cruise_speed = float(cruise_speed)
        self.leg_range = (low, high)
        self.turn_range = (turn_low, turn_high)
        self.reach_radius = float(reach_radius)

    mark_label = "waypoints (the next: larger)"

    def marks(self, goal: dict[str, float]) -> list[np.ndarray]:
        """Each waypoint ahead as the circle of ``reach_radius`` about it, the next one twice as large."""
        ahead = range(int(goal.get("next", 0)), WAYPOINTS)
        return [
            circle_points(goal[f"x{j}"], goal[f"y{j}"], self.reach_radius * (2 if j == ahead.start else 1), 24)
            for j in ahead
        ]

    def observation_bound(self, name: str) -> float:
        bounds = {
            "distance": 2.5 * self.leg_range[1],
            "after_distance": 2.5 * self.leg_range[1],
            "theta": math.pi / 2,
            "remaining": 1.0,
        }
        return bounds.get(name, 1.0 if "bearing" in name else super().observation_bound(name))

    @property
    def goal_ranges(self) -> dict[str, tuple[float, float]]:
        legs = {f"leg_{j}": self.leg_range for j in range(WAYPOINTS)}
        turns = {f"turn_{j}": (self.turn_range if j else (-math.pi, math.pi)) for j in range(WAYPOINTS)}
        return {**legs, **turns}


@kernel
def start(drawn, disk, settings):
    """At the origin, the angles and rates drawn; each waypoint a leg from the one before, turned from the leg before
    (the first from the rolling direction ``(sin psi, -cos psi)``, at the angle ``psi - pi/2`` from the x axis)."""
    psi = drawn[DRAWN_PSI]
    direction0 = psi - 0.5 * math.pi + drawn[DRAWN_TURN]
    direction1 = direction0 + drawn[DRAWN_TURN + 1]
    direction2 = direction1 + drawn[DRAWN_TURN + 2]
    direction3 = direction2 + drawn[DRAWN_TURN + 3]
    x0 = drawn[DRAWN_DISTANCE] * math.cos(direction0)
    y0 = drawn[DRAWN_DISTANCE] * math.sin(direction0)
    x1 = x0 + drawn[DRAWN_DISTANCE + 1] * math.cos(direction1)
    y1 = y0 + drawn[DRAWN_DISTANCE + 1] * math.sin(direction1)
    x2 = x1 + drawn[DRAWN_DISTANCE + 2] * math.cos(direction2)
    y2 = y1 + drawn[DRAWN_DISTANCE + 2] * math.sin(direction2)
    x3 = x2 + drawn[DRAWN_DISTANCE + 3] * math.cos(direction3)
    y3 = y2 + drawn[DRAWN_DISTANCE + 3] * math.sin(direction3)
    goal = (x0, y0, x1, y1, x2, y2, x3, y3, settings[CRUISE_SPEED] / disk[RADIUS], 0.0, 0.0)
    state = (
        0.0,
        0.0,
        drawn[DRAWN_PHI],
        drawn[DRAWN_THETA],
        psi,
        drawn[DRAWN_DPHI],
        drawn[DRAWN_DTHETA],
        drawn[DRAWN_DPSI],
    )
    return goal, state


@inline_kernel
def waypoint(goal, index):
    """``(x, y)`` of the waypoint of ``index`` (0 to 3; the last beyond), m."""
    x = goal[X0] if index < 0.5 else (goal[X1] if index < 1.5 else (goal[X2] if index < 2.5 else goal[X3]))
    y = goal[Y0] if index < 0.5 else (goal[Y1] if index < 1.5 else (goal[Y2] if index < 2.5 else goal[Y3]))
    return x, y


@inline_kernel
def towards(x, trig, point):
    """``(d, sin beta, cos beta, u1, u2)``: the distance (m) from the centre to ``point``, the sine and cosine of its
    bearing from the rolling direction, and the unit vector towards it."""
    dx, dy = point[0] - x[C1], point[1] - x[C2]
    distance = math.sqrt(dx * dx + dy * dy)
    scale = 1.0 / (distance + 1e-9)
    u1, u2 = dx * scale, dy * scale
    sin_bearing, cos_bearing = bearing(trig, u1, u2)
    return distance, sin_bearing, cos_bearing, u1, u2


@inline_kernel
def advance(x, trig, velocity, goal, settings):
    distance = towards(x, trig, waypoint(goal, goal[NEXT]))[0]
    passed = (distance <= settings[REACH_RADIUS]) & (goal[NEXT] < WAYPOINTS)
    return (goal[NEXT] + 1.0 if passed else goal[NEXT], 1.0 if passed else 0.0)


@inline_kernel
def observe(x, trig, velocity, goal, settings):
    distance, sin_bearing, cos_bearing, _, _ = towards(x, trig, waypoint(goal, goal[NEXT]))
    after, after_sin, after_cos, _, _ = towards(x, trig, waypoint(goal, goal[NEXT] + 1.0))
    return (
        distance,
        sin_bearing,
        cos_bearing,
        after,
        after_sin,
        after_cos,
        x[THETA],
        x[DTHETA],
        x[DPHI] - goal[TARGET_DPHI],
        x[DPSI],
        (WAYPOINTS - goal[NEXT]) / WAYPOINTS,
    )


@inline_kernel
def reward_terms(x, trig, velocity, code, effort, goal, settings):
    distance, sin_bearing, cos_bearing, u1, u2 = towards(x, trig, waypoint(goal, goal[NEXT]))
    progress = min(max((velocity[0] * u1 + velocity[1] * u2) / settings[CRUISE_SPEED], -1.0), 1.0)
    miss = distance * abs(sin_bearing) if cos_bearing > 0.0 else distance
    aim = penalty(miss / AIM_SCALE)
    speed = penalty((x[DPHI] - goal[TARGET_DPHI]) / goal[TARGET_DPHI])
    upright = penalty(x[THETA] / settings[FALL_LEAN])
    fallen = (code == FALLEN) | (code == LIFTED_OFF)
    return (
        progress,
        aim,
        speed,
        upright,
        -effort,
        goal[PASSED],
        1.0 if code == REACHED else 0.0,
        -1.0 if fallen else 0.0,
    )


@inline_kernel
def termination(x, goal, settings):
    if abs(x[THETA]) > settings[FALL_LEAN]:
        return FALLEN
    return REACHED if goal[NEXT] >= WAYPOINTS else RUNNING
