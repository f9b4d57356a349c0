"""Constants that every layer of the package shares: the model's domain and the compiled engine's integrators.

This module imports nothing, so that the modules imported with the package (:mod:`rolling_disk_env.dynamics`,
:mod:`rolling_disk_env.integrators`, which must not load numba) and the compiled engine below them
(:mod:`rolling_disk_env.engine`) read the same values without importing each other.
"""

import math

LEAN_MARGIN = 0.01
"""rad. How far from the flat disk (|theta| = pi/2) the model's domain stops: there 1/cos(theta) = 100."""
LEAN_LIMIT = math.pi / 2 - LEAN_MARGIN
"""rad. The model's domain is |theta| < LEAN_LIMIT."""

CONTACTS = ("rolling", "sliding", "coulomb")
"""The contact models (``contact=``; their index is the engine's code for them): the paper's rolling without
slipping; the frozen lake's sliding, with kinetic Coulomb friction of ``friction_coefficient`` (default 0); their
hybrid by Coulomb's law."""
ENGINE_METHODS = ("euler", "symplectic_euler", "rk4", "dopri5")
"""The methods the compiled engine integrates (their index is the engine's code for them): fixed steps, then the
error-controlled Dormand-Prince 5(4)."""

INFO_SETS = ("full", "training")
"""What a batch's step writes beside the observations, rewards and flags (``info_keys`` of the vector envs): every row
of the info block (``"full"``: the state, energy, contact forces, normal force, required friction and reward terms),
or only the termination codes (``"training"``: what autoreset, ``final_obs`` and ``final_info``, the success rate and
the trainers read). Each is a variant of every generated step function (:func:`set_suffix`): a step asked for less
compiles less and writes less."""


def set_suffix(info_keys: str) -> str:
    """The suffix of a generated step function's name for an info set of :data:`INFO_SETS`: none for ``"full"``."""
    return "" if info_keys == "full" else f"_{info_keys}"


ZERO_SLIP = 1e-12
"""A slip speed below ``ZERO_SLIP * sqrt(g r)`` counts as zero: the round-off of a rolling state's slip."""
EVENT_TIME_TOLERANCE = 1e-13
"""s. How closely the root-finding brackets a switching event's time (far below the integrators' own error)."""
STOP_SLIP = 1e-10
"""A slide stops where its slip speed falls below ``STOP_SLIP * sqrt(g r)`` (3.1e-10 m/s for the paper's disk): the
contact impulse that then zeroes the slip changes the energy by ``m |v|^2 / 2`` at most, some 1e-19 J."""
