"""rolling-disk-env: a disk rolling without slipping on a plane (L. Jaulin's SymPy model) as a Gymnasium env.

Importing the package registers ``"RollingDisk-v0"`` with Gymnasium (idempotently, so that ``SubprocVecEnv``
children, which import it again, find the id).
"""

from gymnasium.envs.registration import register, registry

from rolling_disk_env.dynamics import (
    LEAN_LIMIT,
    LEAN_MARGIN,
    DiskParams,
    OutOfDomainError,
    contact_force,
    energy,
    lean_derivative,
    lean_state,
    state_derivative,
    steady_circle_spin_rate,
)
from rolling_disk_env.envs import RollingDiskEnv, RollingDiskVectorEnv
from rolling_disk_env.integrators import METHODS, simulate

ENV_ID = "RollingDisk-v0"
MAX_EPISODE_STEPS = 500
"""Steps of 0.02 s in an episode (10 s)."""

if ENV_ID not in registry:
    register(
        id=ENV_ID,
        entry_point="rolling_disk_env.envs:RollingDiskEnv",
        vector_entry_point="rolling_disk_env.envs:RollingDiskVectorEnv",
        max_episode_steps=MAX_EPISODE_STEPS,
        reward_threshold=450.0,
    )

__all__ = [
    "ENV_ID",
    "LEAN_LIMIT",
    "LEAN_MARGIN",
    "MAX_EPISODE_STEPS",
    "METHODS",
    "DiskParams",
    "OutOfDomainError",
    "RollingDiskEnv",
    "RollingDiskVectorEnv",
    "contact_force",
    "energy",
    "lean_derivative",
    "lean_state",
    "simulate",
    "state_derivative",
    "steady_circle_spin_rate",
]
