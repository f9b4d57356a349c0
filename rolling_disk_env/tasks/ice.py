"""``task="ice"``: ``goto`` on a slippery plane, where the disk slides as soon as it asks more than friction gives.

The task runs under Coulomb's contact (``contact="coulomb"``, :doc:`the contact models <../model/contact>`) with a
friction coefficient of 0.1 by default (ice; wet asphalt is about 0.4): the contact rolls while the horizontal force it
needs stays within mu times the normal force, and slides otherwise. Turning hard, braking or spinning up fast asks
for more, and a sliding disk turns and balances badly. The agent has to reach the target of ``goto`` while keeping
the contact inside the friction cone; the observation adds the contact point's slip velocity, so that, with the rest,
it holds the whole state of the sliding model but for the disk's place and heading, which the target's distance and
bearing stand for.

On Coulomb's contact only: ``rolling_disk_env.jax`` has no Coulomb contact and refuses the task (its env checks the
contact).
"""

from __future__ import annotations

from typing import ClassVar

from rolling_disk_env.jit import inline_kernel
from rolling_disk_env.tasks import goto
from rolling_disk_env.tasks.base import COS_PSI, COS_THETA, DPHI, DPSI, DTHETA, SIN_PSI, SIN_THETA
from rolling_disk_env.tasks.goto import CRUISE_SPEED, TARGET_DPHI, GotoTask, start, termination

__all__ = ["IceTask", "observe", "reward_terms", "start", "termination"]  # start and termination: goto's

ICE = 0.1
"""The friction coefficient of the task by default (ice)."""
SLIP_SCALE = 0.1
"""m/s. The slip speed at which the ``grip`` penalty saturates."""


class IceTask(GotoTask):
    """``goto`` under Coulomb's contact at ``friction_coefficient`` = 0.1: reach the target without falling, sliding
    as little as it can.

    Observation (float32): ``goto``'s (:class:`rolling_disk_env.tasks.goto.GotoTask`), then ``slip_forward`` and
    ``slip_lateral``, the contact point's slip velocity along the rolling direction ``(sin psi, -cos psi)`` and to its
    left (m/s, clipped to +-10; zero while the disk rolls). With the sliding model's state, the slip is the centre's
    velocity less the one the rolling constraint gives the disk's angles and rates.

    Reward terms: ``goto``'s, then ``grip`` -min((|slip| / 0.1 m/s)^2, 1) (weight 0.5).

    Initial state, target and success as ``goto``'s; the env's contact is ``"coulomb"`` (no other is accepted) and its
    ``friction_coefficient`` 0.1 unless given (``params_ranges={"friction_coefficient": (low, high)}`` draws it per
    episode).
    """

    name = "ice"
    observation_names = (*GotoTask.observation_names, "slip_forward", "slip_lateral")
    default_reward_weights: ClassVar[dict[str, float]] = {**GotoTask.default_reward_weights, "grip": 0.5}
    contact = "coulomb"
    friction_coefficient = ICE

    def observation_bound(self, name: str) -> float:
        return 10.0 if name.startswith("slip") else super().observation_bound(name)


@inline_kernel
def slip(x, trig, velocity, goal, settings):
    """``(forward, lateral)``: the contact point's slip velocity (m/s) along the rolling direction and to its left:
    the centre's ``velocity`` less the rolling constraint's, ``r (dphi - dpsi sin theta)`` forward and
    ``r cos(theta) dtheta`` to the left, the radius ``r`` from the goal's spin rate (``cruise_speed / r``)."""
    r = settings[CRUISE_SPEED] / goal[TARGET_DPHI]
    sin_psi, cos_psi = trig[SIN_PSI], trig[COS_PSI]
    forward = velocity[0] * sin_psi - velocity[1] * cos_psi - r * (x[DPHI] - x[DPSI] * trig[SIN_THETA])
    lateral = velocity[0] * cos_psi + velocity[1] * sin_psi - r * trig[COS_THETA] * x[DTHETA]
    return forward, lateral


@inline_kernel
def observe(x, trig, velocity, goal, settings):
    return (*goto.observe(x, trig, velocity, goal, settings), *slip(x, trig, velocity, goal, settings))


@inline_kernel
def reward_terms(x, trig, velocity, code, effort, goal, settings):
    forward, lateral = slip(x, trig, velocity, goal, settings)
    grip = -min((forward * forward + lateral * lateral) / (SLIP_SCALE * SLIP_SCALE), 1.0)
    return (*goto.reward_terms(x, trig, velocity, code, effort, goal, settings), grip)
