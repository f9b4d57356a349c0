"""``task="recovery"``: bring a disk that circles at a large lean back to steady upright rolling.

A disk leaning by theta and turning at dpsi rolls on a steady circle when its spin rate is the paper's circle
condition solved for dphi (:func:`rolling_disk_env.dynamics.steady_motion`): ``dphi = 2 g tan(theta) / (3 r dpsi) +
5 dpsi sin(theta) / 6``. This task starts the disk near such a circle at a lean of 0.6 to 1.2 rad (34 to 69 degrees),
either side, turning into the lean at 1.5 to 3 rad/s, with its lean rate, spin and heading rates perturbed. The agent
has to stand it up with the spin and steer torques alone (the lean is reached only through the gyroscopic coupling)
and keep it upright, still rolling, for ``hold_steps`` control periods. Its fall lean is 1.4 rad, below the model's
domain :data:`rolling_disk_env.LEAN_LIMIT`.

What makes it hard: far from upright the linearization about upright rolling misleads (the LQR about upright rolling
at the disk's own spin rate, :class:`agents.baselines.RecoveryLQR`, fails on most starts, ``benchmarks/results/
learning.md``), the torques saturate, and the way up passes through fast turning. A planner on the exact model
recovers most starts (:class:`agents.planner.CEMPlanner`): the headroom is what a policy can learn.
"""

from __future__ import annotations

import math
from typing import ClassVar

from rolling_disk_env.dynamics import is_number
from rolling_disk_env.engine import FALLEN, LIFTED_OFF, REACHED, RUNNING
from rolling_disk_env.jit import inline_kernel, kernel
from rolling_disk_env.tasks.base import DPHI, DPSI, DTHETA, GRAVITY, RADIUS, REACH, THETA, Task, penalty

# Positions in this task's arrays.
FALL_LEAN, UPRIGHT_LEAN, RATE_BOUND, HOLD_STEPS, TARGET_SPEED, SPIN_BOUND = range(6)  # settings
TARGET_DPHI, HELD = range(2)  # goal: the target spin rate, then the progress
(
    DRAWN_LEAN,  # initial ranges
    DRAWN_SIDE,
    DRAWN_TURN_RATE,
    DRAWN_DTHETA,
    DRAWN_SPIN_ERROR,
    DRAWN_DPSI_ERROR,
    DRAWN_PHI,
    DRAWN_PSI,
) = range(8)
RATE_SCALE = 2.0
"""rad/s. The lean and heading rates at which the ``rates`` penalty saturates."""


class RecoveryTask(Task):
    """Stand a disk circling at a large lean up, to steady upright rolling.

    Observation (float32): ``theta`` (rad), ``dtheta``, ``dphi``, ``dpsi`` (rad/s): the lean model's state, which the
    task's goal does not tie to a place or a heading, so it is the whole state that matters; and ``held``, the
    fraction of ``hold_steps`` the disk has been upright so far (0 to 1).

    Upright: ``|theta| <= upright_lean`` (0.1 rad), ``|dtheta| <= rate_bound`` and ``|dpsi| <= rate_bound`` (0.3
    rad/s). The progress ``held`` counts the consecutive control periods the disk ends upright (0 when it leaves).

    Reward terms (weights: ``reward_weights``), each in [-1, 1]: ``upright`` -min((theta / fall_lean)^2, 1);
    ``rates`` -min((dtheta^2 + dpsi^2) / (2 rad/s)^2, 1); ``effort`` minus the mean squared normalized action;
    ``recovered`` +1 on the step upright rolling has been held ``hold_steps`` periods (``Termination.REACHED``, the
    episode's last); ``fallen`` -1 on the step it falls or lifts off. Default weights 1, 0.2, 0.1, 100, 100: a recovery
    is worth 100, a fall costs 100.

    Initial state: ``c1 = c2 = 0``, ``phi`` and ``psi`` uniform; a steady circle of lean ``theta0 = s lean`` and heading
    rate ``s turn_rate``, ``lean`` drawn from [0.6, 1.2] rad, ``turn_rate`` from [1.5, 3] rad/s, the side ``s`` = +1
    or -1 (``side`` drawn from [-1, 1], its sign), with the spin rate of the circle condition times ``1 + spin_error``
    (``spin_error`` in [-0.05, 0.05]), the heading rate plus ``dpsi_error`` (in [-0.1, 0.1] rad/s) and the lean rate
    ``dtheta`` (in [-0.3, 0.3] rad/s) (``initial_ranges``). Every start has a positive normal force
    (``tests/test_recovery.py``).

    Success: upright rolling held for ``hold_steps`` control periods (50: 1 s at the default dt) without falling
    (|theta| > ``fall_lean`` = 1.4 rad); the episode then terminates (``Termination.REACHED``).
    """

    name = "recovery"
    observation_names = ("theta", "dtheta", "dphi_error", "dpsi", "held")
    default_reward_weights: ClassVar[dict[str, float]] = {
        "upright": 1.0,
        "rates": 0.2,
        "speed": 0.3,
        "effort": 0.1,
        "recovered": 100.0,
        "fallen": 100.0,
    }
    goal_names = ("dphi",)
    progress_names = ("held",)
    setting_names = ("fall_lean", "upright_lean", "rate_bound", "hold_steps", "target_speed", "spin_bound")
    default_initial_ranges: ClassVar[dict[str, tuple[float, float]]] = {
        "lean": (0.8, 1.25),
        "side": (-1.0, 1.0),
        "turn_rate": (2.5, 4.0),
        "dtheta": (-0.5, 0.5),
        "spin_error": (-0.05, 0.05),
        "dpsi_error": (-0.1, 0.1),
        "phi": (-math.pi, math.pi),
        "psi": (-math.pi, math.pi),
    }
    fall_lean = 1.4
    success = REACH

    def __init__(
        self,
        target_speed: float = 2.0,
        upright_lean: float = 0.1,
        rate_bound: float = 0.3,
        spin_bound: float = 0.3,
        hold_steps: int = 50,
        **kwargs,
    ):
        """
        Args:
            upright_lean: rad. The largest |theta| that counts as upright.
            rate_bound: rad/s. The largest |dtheta| and |dpsi| that count as upright rolling.
            hold_steps: control periods of upright rolling in a row that end the episode as a success.
            **kwargs: ``reward_weights``, ``fall_lean`` (see :class:`Task`).
        """
        super().__init__(**kwargs)
        if not (is_number(upright_lean) and 0 < upright_lean < self.fall_lean):
            raise ValueError(
                f"upright_lean must be a number in (0, fall_lean = {self.fall_lean}) rad, got {upright_lean!r}"
            )
        if not (is_number(rate_bound) and math.isfinite(rate_bound) and rate_bound > 0):
            raise ValueError(f"rate_bound must be a finite number > 0 (rad/s), got {rate_bound!r}")
        if not (isinstance(hold_steps, int) and not isinstance(hold_steps, bool) and hold_steps >= 1):
            raise ValueError(f"hold_steps must be an integer >= 1, got {hold_steps!r}")
        if not (is_number(target_speed) and math.isfinite(target_speed) and target_speed > 0):
            raise ValueError(f"target_speed must be a finite number > 0 (m/s), got {target_speed!r}")
        if not (is_number(spin_bound) and math.isfinite(spin_bound) and spin_bound > 0):
            raise ValueError(f"spin_bound must be a finite number > 0 (rad/s), got {spin_bound!r}")
        self.upright_lean, self.rate_bound, self.hold_steps = float(upright_lean), float(rate_bound), hold_steps
        self.target_speed, self.spin_bound = float(target_speed), float(spin_bound)

    def initial_ranges(self, overrides):
        ranges = super().initial_ranges(overrides)
        low, high = ranges["lean"]
        if not (0 <= low and high < self.fall_lean):
            raise ValueError(
                f"initial-state range 'lean' {ranges['lean']} must lie in [0, fall_lean = {self.fall_lean}) rad"
            )
        if not ranges["turn_rate"][0] > 0:
            raise ValueError(f"initial-state range 'turn_rate' {ranges['turn_rate']} must be > 0 rad/s")
        return ranges

    def observation_bound(self, name: str) -> float:
        return {"theta": math.pi / 2, "held": 1.0}.get(name, super().observation_bound(name))


@kernel
def start(drawn, disk, settings):
    """At the origin, on the steady circle of the drawn lean and turn rate (both of the drawn side), perturbed."""
    side = 1.0 if drawn[DRAWN_SIDE] >= 0.0 else -1.0
    theta, dpsi = side * drawn[DRAWN_LEAN], side * drawn[DRAWN_TURN_RATE]
    g, r = disk[GRAVITY], disk[RADIUS]
    dphi = 2.0 * g * math.tan(theta) / (3.0 * r * dpsi) + 5.0 * dpsi * math.sin(theta) / 6.0
    x = (
        0.0,
        0.0,
        drawn[DRAWN_PHI],
        theta,
        drawn[DRAWN_PSI],
        dphi * (1.0 + drawn[DRAWN_SPIN_ERROR]),
        drawn[DRAWN_DTHETA],
        dpsi + drawn[DRAWN_DPSI_ERROR],
    )
    return (settings[TARGET_SPEED] / r, 0.0), x


@inline_kernel
def upright(x, goal, settings):
    """Whether the disk rolls upright: lean within ``upright_lean``, lean and heading rates within ``rate_bound``."""
    bound = settings[RATE_BOUND]
    spin = abs(x[DPHI] - goal[TARGET_DPHI]) <= settings[SPIN_BOUND]
    return (abs(x[THETA]) <= settings[UPRIGHT_LEAN]) & (abs(x[DTHETA]) <= bound) & (abs(x[DPSI]) <= bound) & spin


@inline_kernel
def advance(x, trig, velocity, goal, settings):
    return ((goal[HELD] + 1.0) if upright(x, goal, settings) else 0.0,)


@inline_kernel
def observe(x, trig, velocity, goal, settings):
    return (x[THETA], x[DTHETA], x[DPHI] - goal[TARGET_DPHI], x[DPSI], goal[HELD] / settings[HOLD_STEPS])


@inline_kernel
def reward_terms(x, trig, velocity, code, effort, goal, settings):
    lean = penalty(x[THETA] / settings[FALL_LEAN])
    rates = -min((x[DTHETA] * x[DTHETA] + x[DPSI] * x[DPSI]) / (RATE_SCALE * RATE_SCALE), 1.0)
    speed = penalty((x[DPHI] - goal[TARGET_DPHI]) / goal[TARGET_DPHI])
    fallen = (code == FALLEN) | (code == LIFTED_OFF)
    return (lean, rates, speed, -effort, 1.0 if code == REACHED else 0.0, -1.0 if fallen else 0.0)


@inline_kernel
def termination(x, goal, settings):
    if abs(x[THETA]) > settings[FALL_LEAN]:
        return FALLEN
    return REACHED if goal[HELD] >= settings[HOLD_STEPS] else RUNNING
