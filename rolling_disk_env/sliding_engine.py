"""The sliding model's compiled loops: the model API's batch loops and the Coulomb hybrid's derivative.

Compiled by numba (:mod:`rolling_disk_env.jit`) over the generated kernels of ``_generated/sliding.py``, as the
engine (:mod:`rolling_disk_env.engine`) does for the rolling model; kept apart from the engine while the env's
integration of the contact models is pending, to join it then. States are rows of 10 floats,
``(c1, c2, phi, theta, psi, dc1, dc2, dphi, dtheta, dpsi)``; torques rows ``(tau_spin, tau_steer)`` (N m); disks rows
``(m, g, r)``.
"""

from __future__ import annotations

from rolling_disk_env._generated import sliding
from rolling_disk_env.jit import inline_kernel, kernel


@kernel
def derivatives(states, torques, frictions, disks, out):
    """dx/dt of the sliding model under kinetic friction for each row; ``frictions[i]`` is row i's coefficient."""
    for i in range(states.shape[0]):
        u, disk = torques[i], disks[i]
        values = sliding.sliding_derivative(states[i], u[0], u[1], frictions[i], disk[0], disk[1], disk[2])
        for j in range(10):
            out[i, j] = values[j]


@kernel
def diagnostics(states, torques, frictions, disks, out):
    """``(energy, normal_force, F1, F2, v1, v2)`` under kinetic friction for each row: ``out`` (N, 6)."""
    for i in range(states.shape[0]):
        u, disk = torques[i], disks[i]
        values = sliding.sliding_diagnostics(states[i], u[0], u[1], frictions[i], disk[0], disk[1], disk[2])
        for j in range(6):
            out[i, j] = values[j]


@inline_kernel
def hybrid_friction(x, mu, onset, reference, zero_slip, r):
    """The friction per unit normal force ``(f1, f2)`` of a sliding disk of the Coulomb hybrid.

    Where the slip speed exceeds ``zero_slip`` (m/s), the kinetic law ``-mu v / |v|``; but reversed where the slip
    points against ``reference`` (a direction, or zeros for none): past a stop inside an integration step, so that
    the friction of the approach continues smoothly through it and the stop is a root of ``v . reference`` (what the
    hybrid locates). At zero slip, ``onset``: the friction the rolling contact needed, at its limit mu.
    """
    v1, v2 = sliding.slip_velocity(x, r)
    if v1 * v1 + v2 * v2 <= zero_slip * zero_slip:
        return onset[0], onset[1]
    f1, f2 = sliding.kinetic_friction(x, mu, r)
    if v1 * reference[0] + v2 * reference[1] < 0.0:
        return -f1, -f2
    return f1, f2


@kernel
def hybrid_derivative(x, u, mu, onset, reference, zero_slip, disk, out):
    """dx/dt of a sliding disk of the Coulomb hybrid (friction from :func:`hybrid_friction`) into ``out`` (10,)."""
    f1, f2 = hybrid_friction(x, mu, onset, reference, zero_slip, disk[2])
    values = sliding.friction_derivative(x, u[0], u[1], f1, f2, disk[0], disk[1], disk[2])
    for j in range(10):
        out[j] = values[j]


@kernel
def hybrid_diagnostics(x, u, mu, onset, reference, zero_slip, disk):
    """``(energy, normal_force, F1, F2, v1, v2)`` of a sliding disk of the Coulomb hybrid."""
    f1, f2 = hybrid_friction(x, mu, onset, reference, zero_slip, disk[2])
    energy, normal, v1, v2 = sliding.friction_diagnostics(x, u[0], u[1], f1, f2, disk[0], disk[1], disk[2])
    return energy, normal, normal * f1, normal * f2, v1, v2
