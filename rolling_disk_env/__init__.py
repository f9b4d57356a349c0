"""rolling-disk-env: a disk rolling without slipping on a plane (L. Jaulin's SymPy model) as a Gymnasium env."""

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
from rolling_disk_env.integrators import METHODS, simulate

__all__ = [
    "LEAN_LIMIT",
    "LEAN_MARGIN",
    "METHODS",
    "DiskParams",
    "OutOfDomainError",
    "contact_force",
    "energy",
    "lean_derivative",
    "lean_state",
    "simulate",
    "state_derivative",
    "steady_circle_spin_rate",
]
