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

from rolling_disk_env.tasks.base import Task


class UprightTask(Task):
    """Stay upright while rolling at ``target_speed``.

    Observation (float32): ``theta`` (rad), ``dtheta``, ``dphi - dphi*`` and ``dpsi`` (rad/s), where
    ``dphi* = target_speed / r``.

    Reward terms (weights: ``reward_weights``):
        ``alive`` 1 every step; ``lean`` -(theta / fall_lean)^2; ``speed`` -min(((dphi - dphi*) / dphi*)^2, 1);
        ``effort`` minus the mean squared normalized action.

    Initial state: ``c1 = c2 = 0``; ``phi``, ``psi``, ``theta``, ``dtheta``, ``dphi``, ``dpsi`` uniform in
    ``initial_ranges`` (rad, rad/s; by default phi and psi in [-pi, pi]).

    Success: the episode reaches truncation without falling (|theta| > ``fall_lean`` = 0.5 rad).
    """

    name = "upright"
    needs_position = False
    observation_names = ("theta", "dtheta", "dphi_error", "dpsi")
    default_reward_weights: ClassVar[dict[str, float]] = {"alive": 1.0, "lean": 1.0, "speed": 0.5, "effort": 0.1}
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
        if not (math.isfinite(target_speed) and target_speed > 0):
            raise ValueError(f"target_speed must be a finite number > 0 (m/s), got {target_speed!r}")
        self.target_speed = float(target_speed)

    def observation_bound(self, name: str) -> float:
        return math.pi / 2 if name == "theta" else super().observation_bound(name)

    def target_spin_rate(self, disk_radius):
        """dphi* = target_speed / r (rad/s), for a disk of radius ``disk_radius`` (m; a float or an array)."""
        return self.target_speed / disk_radius

    def goal(self, drawn, constants, xp) -> dict:
        return {"dphi": self.target_spin_rate(constants[2])}

    def initial_state(self, drawn, constants, goal, xp) -> list:
        v = drawn
        return [0.0, 0.0, v["phi"], v["theta"], v["psi"], v["dphi"], v["dtheta"], v["dpsi"]]

    def observe(self, x, goal, xp) -> list:
        return [x[3], x[6], x[5] - goal["dphi"], x[7]]

    def reward_terms(self, x, effort, goal, xp) -> dict:
        return {
            "alive": 1.0,
            "lean": self.penalty(x[3] / self.fall_lean, xp),
            "speed": self.penalty((x[5] - goal["dphi"]) / goal["dphi"], xp),
            "effort": -effort,
        }
