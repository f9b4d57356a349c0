"""``task="upright"``: keep a disk that rolls too slowly to stabilize itself upright, at a target speed.

A disk rolling upright at spin rate dphi is self-stabilizing iff dphi^2 > g / (3 r). This task starts it below that
speed, with a small random lean, so a passive disk falls; the lean is not directly actuated (its row of the input
matrix B is zero) and the steer torque reaches it only through the gyroscopic term -6/5 dphi dpsi cos(theta) of
ddtheta, the spin torque through dphi. The linearization about upright rolling at the target speed is controllable
(see ``tests/test_tasks.py``).
"""

from __future__ import annotations

import math
from typing import ClassVar

from rolling_disk_env.dynamics import is_number
from rolling_disk_env.engine import FALLEN, RUNNING
from rolling_disk_env.jit import inline_kernel, kernel
from rolling_disk_env.tasks.base import DPHI, DPSI, DTHETA, RADIUS, THETA, Task, penalty

# Positions in this task's arrays.
TARGET_SPEED, FALL_LEAN = range(2)  # settings
TARGET_DPHI = 0  # goal
DRAWN_PHI, DRAWN_PSI, DRAWN_THETA, DRAWN_DTHETA, DRAWN_DPHI, DRAWN_DPSI = range(6)  # initial ranges


class UprightTask(Task):
    """Stay upright while rolling at ``target_speed``.

    Observation (float32): ``theta`` (rad), ``dtheta``, ``dphi - dphi*`` and ``dpsi`` (rad/s), where
    ``dphi* = target_speed / r``.

    Reward terms (weights: ``reward_weights``):
        ``alive`` 1 every step; ``lean`` -min((theta / fall_lean)^2, 1); ``speed`` -min(((dphi - dphi*) / dphi*)^2, 1);
        ``effort`` minus the mean squared normalized action.

    Initial state: ``c1 = c2 = 0``; ``phi``, ``psi``, ``theta``, ``dtheta``, ``dphi``, ``dpsi`` uniform in
    ``initial_ranges`` (rad, rad/s; by default phi and psi in [-pi, pi]).

    Success: the episode reaches truncation without falling (|theta| > ``fall_lean`` = 0.5 rad).
    """

    name = "upright"
    observation_names = ("theta", "dtheta", "dphi_error", "dpsi")
    default_reward_weights: ClassVar[dict[str, float]] = {"alive": 1.0, "lean": 1.0, "speed": 0.5, "effort": 0.1}
    goal_names = ("dphi",)
    setting_names = ("target_speed", "fall_lean")
    default_initial_ranges: ClassVar[dict[str, tuple[float, float]]] = {
        "phi": (-math.pi, math.pi),
        "psi": (-math.pi, math.pi),
        "theta": (-0.05, 0.05),
        "dtheta": (-0.1, 0.1),
        "dphi": (0.8, 1.2),
        "dpsi": (-0.1, 0.1),
    }
    fall_lean = 0.5

    def __init__(self, target_speed: float = 1.0, **kwargs):
        """
        Args:
            target_speed: rolling speed r * dphi to hold, m/s (default 1.0: dphi* = 1 rad/s for the default disk,
                below the self-stabilizing 1.81 rad/s).
            **kwargs: ``reward_weights``, ``fall_lean`` (see :class:`Task`).
        """
        super().__init__(**kwargs)
        if not (is_number(target_speed) and math.isfinite(target_speed) and target_speed > 0):
            raise ValueError(f"target_speed must be a finite number > 0 (m/s), got {target_speed!r}")
        self.target_speed = float(target_speed)

    def observation_bound(self, name: str) -> float:
        return math.pi / 2 if name == "theta" else super().observation_bound(name)

    def target_spin_rate(self, disk_radius: float) -> float:
        """dphi* (rad/s) for a disk of radius ``disk_radius`` (m)."""
        return target_spin_rate(self.target_speed, disk_radius)


@kernel
def target_spin_rate(target_speed, disk_radius):
    """dphi* = target_speed / r (rad/s): rolling without slipping at the target speed (m/s)."""
    return target_speed / disk_radius


@kernel
def start(drawn, disk, settings):
    """At the origin, the angles and rates drawn; the goal is the spin rate of the target speed."""
    goal = (target_spin_rate(settings[TARGET_SPEED], disk[RADIUS]),)
    phi, psi, theta = drawn[DRAWN_PHI], drawn[DRAWN_PSI], drawn[DRAWN_THETA]
    x = (0.0, 0.0, phi, theta, psi, drawn[DRAWN_DPHI], drawn[DRAWN_DTHETA], drawn[DRAWN_DPSI])
    return goal, x


@inline_kernel
def observe(x, trig, velocity, goal, settings):
    return (x[THETA], x[DTHETA], x[DPHI] - goal[TARGET_DPHI], x[DPSI])


@inline_kernel
def reward_terms(x, trig, velocity, code, effort, goal, settings):
    alive = 1.0
    lean = penalty(x[THETA] / settings[FALL_LEAN])
    speed = penalty((x[DPHI] - goal[TARGET_DPHI]) / goal[TARGET_DPHI])
    return (alive, lean, speed, -effort)


@inline_kernel
def termination(x, goal, settings):
    return FALLEN if abs(x[THETA]) > settings[FALL_LEAN] else RUNNING
