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

from rolling_disk_env.dynamics import steady_circles
from rolling_disk_env.tasks.base import Task


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

    Success: not falling (|theta| > ``fall_lean`` = 0.8 rad) and a mean |e_r| over the last half of the episode of
    at most ``success_bound`` = 0.25 m.
    """

    name = "circle"
    needs_position = True
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
    success_bound = 0.25
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
        low, high = (float(v) for v in radius_range)
        if not (math.isfinite(target_speed) and target_speed > 0):
            raise ValueError(f"target_speed must be a finite number > 0 (m/s), got {target_speed!r}")
        if not (math.isfinite(high) and 0 < low <= high):
            raise ValueError(f"radius_range must satisfy 0 < low <= high (m), got {radius_range!r}")
        self.target_speed = float(target_speed)
        self.radius_range = (low, high)
        self.centre = tuple(float(v) for v in centre)

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

    def goal(self, drawn, constants, xp) -> dict:
        _, gravity, disk_radius = constants
        theta, dphi, dpsi = steady_circles(drawn["radius"], self.target_speed, gravity, disk_radius)
        return {
            "radius": drawn["radius"],
            "cx": self.centre[0],
            "cy": self.centre[1],
            "theta": theta,
            "dphi": dphi,
            "dpsi": dpsi,
        }

    def initial_state(self, drawn, constants, goal, xp) -> list:
        v = drawn
        distance = goal["radius"] + v["radial_offset"]
        c1 = goal["cx"] + distance * xp.cos(v["angle"])
        c2 = goal["cy"] + distance * xp.sin(v["angle"])
        # Rolling direction (sin psi, -cos psi) along the counter-clockwise tangent (-sin a, cos a): psi = a + pi.
        psi = v["angle"] + math.pi + v["heading_error"]
        return [c1, c2, v["phi"], v["theta"], psi, goal["dphi"] * (1 + v["dphi_error"]), v["dtheta"], v["dpsi"]]

    def _polar(self, x, goal, xp):
        dx, dy = x[0] - goal["cx"], x[1] - goal["cy"]
        distance = xp.sqrt(dx * dx + dy * dy)
        return dx, dy, distance

    def observe(self, x, goal, xp) -> list:
        dx, dy, distance = self._polar(x, goal, xp)
        sin_psi, cos_psi = xp.sin(x[4]), xp.cos(x[4])
        # delta = psi - angle - pi, with (cos angle, sin angle) = (dx, dy) / distance.
        scale = 1.0 / (distance + 1e-9)
        return [
            distance - goal["radius"],
            (cos_psi * dy - sin_psi * dx) * scale,
            -(cos_psi * dx + sin_psi * dy) * scale,
            x[3] - goal["theta"],
            x[6],
            x[5] - goal["dphi"],
            x[7] - goal["dpsi"],
            goal["theta"],
        ]

    def reward_terms(self, x, effort, goal, xp) -> dict:
        return {
            "alive": 1.0,
            "radial": self.penalty(self._polar(x, goal, xp)[2] - goal["radius"], xp),
            "speed": self.penalty((x[5] - goal["dphi"]) / goal["dphi"], xp),
            "effort": -effort,
        }

    def tracking_error(self, x, goal, xp):
        return xp.abs(self._polar(x, goal, xp)[2] - goal["radius"])
