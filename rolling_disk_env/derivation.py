"""Symbolic derivation of the rolling-disk state equations with SymPy.

This module follows L. Jaulin, *Modelisation of a rolling disk with Sympy*, section by section, so that it can be
read beside the paper. It is the only module of the package that imports SymPy; nothing imports it at run time.
``rolling_disk_env.codegen`` turns its result into the committed numeric code in ``rolling_disk_env/_generated``.

Conventions (the paper's):

* World frame: ``x, y`` horizontal, ``z`` up (m). The generalized coordinates are
  ``q = (c1, c2, phi, theta, psi)``: ``(c1, c2)`` the horizontal position of the disk's centre (m), ``phi`` the spin
  angle, ``theta`` the stand (lean) angle, 0 when the disk is vertical, and ``psi`` the heading (rad).
* Orientation ``R = R_psi R_theta R_phi`` (rotations about z, y, x). The body ``x`` axis ``R e1`` is the disk's
  symmetry axis; a thin uniform disk has inertia ``diag(m r^2 / 2, m r^2 / 4, m r^2 / 4)`` in the body frame.
* The state is ``x = (c1, c2, phi, theta, psi, dphi, dtheta, dpsi)``.

Extension beyond the paper: two input torques applied to the disk, in N m,

* ``tau_spin`` about the disk's own symmetry axis ``R e1``,
* ``tau_steer`` about the vertical ``+z``,

mapped to generalized forces by virtual power, ``Q_torque = J_omega(q)^T T`` with ``omega_world = J_omega(q) dq/dt``.
The result is control-affine: ``ddq = f(q, dq) + B(q) u`` and ``lambda = lambda_f(q, dq) + lambda_B(q) u``, with
``u = (tau_spin, tau_steer)``.

Also derived: the vertical ground reaction ``N = m (g + c3'')``, ``c3 = r cos(theta)`` being the centre's height (N).
With the horizontal reaction lambda it says when rolling holds: the contact slips unless ``|lambda| <= mu N`` for
the friction coefficient mu, and lifts off unless ``N > 0``.

Beyond the paper's rolling disk, :func:`derive_sliding` derives the disk that slides, the paper's "flat frozen lake"
(section 2.4) with dry friction added: the same Lagrangian (``c3 = r cos(theta)`` still eliminated by the contact),
no rolling constraint, so the state is ``(q, dq)``, ten numbers; the same torques; and a horizontal force ``F`` at
the contact, whose generalized force comes by virtual power at the material contact point, whose horizontal
velocity is ``A(q) dq``. With ``F = N f`` (``f`` the friction per unit normal force) the normal force ``N`` enters the
equations of motion, so it is solved with the accelerations. Kinetic Coulomb friction is ``f = -mu v / |v|``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import sympy as sp

# Section 2.1, symbolic variables. Time, the disk's constants and the generalized coordinates q(t).
t = sp.Symbol("t")
m, g, r = sp.symbols("m g r", positive=True)
c1_t, c2_t, phi_t, theta_t, psi_t = (sp.Function(name)(t) for name in ("c1", "c2", "phi", "theta", "psi"))
q_t = sp.Matrix([c1_t, c2_t, phi_t, theta_t, psi_t])

# Plain symbols for the same quantities once time derivatives have been taken: these name the arguments of the
# generated code. Order of the state: x = (c1, c2, phi, theta, psi, dphi, dtheta, dpsi).
c1, c2, phi, theta, psi = sp.symbols("c1 c2 phi theta psi")
dc1, dc2, dphi, dtheta, dpsi = sp.symbols("dc1 dc2 dphi dtheta dpsi")
ddc1, ddc2, ddphi, ddtheta, ddpsi = sp.symbols("ddc1 ddc2 ddphi ddtheta ddpsi")
lambda1, lambda2 = sp.symbols("lambda1 lambda2")
tau_spin, tau_steer = sp.symbols("tau_spin tau_steer")
normal, f1, f2, v1, v2 = sp.symbols("normal f1 f2 v1 v2")
mu = sp.Symbol("mu", nonnegative=True)
slip_speed = sp.Symbol("slip_speed", positive=True)

q = sp.Matrix([c1, c2, phi, theta, psi])
dq = sp.Matrix([dc1, dc2, dphi, dtheta, dpsi])
ddq = sp.Matrix([ddc1, ddc2, ddphi, ddtheta, ddpsi])
multipliers = sp.Matrix([lambda1, lambda2])
torques = sp.Matrix([tau_spin, tau_steer])
state = (c1, c2, phi, theta, psi, dphi, dtheta, dpsi)
friction_ratio = sp.Matrix([f1, f2])
"""The horizontal contact force on the disk per unit normal force, along world x and y (``|f| <= mu``)."""
slip = sp.Matrix([v1, v2])
"""The slip velocity: the horizontal velocity of the disk's material contact point, along world x and y (m/s)."""
slip_change = sp.Matrix(sp.symbols("dv1 dv2"))
"""A change of the slip velocity (m/s), which a contact impulse makes."""
sliding_state = (c1, c2, phi, theta, psi, dc1, dc2, dphi, dtheta, dpsi)


def to_symbols(expr: sp.Expr | sp.Matrix) -> sp.Expr | sp.Matrix:
    """Replaces q(t) and its first two time derivatives by the plain symbols q, dq, ddq."""
    second = {qi.diff(t, 2): ddqi for qi, ddqi in zip(q_t, ddq)}
    first = {qi.diff(t): dqi for qi, dqi in zip(q_t, dq)}
    coordinates = dict(zip(q_t, q))
    return expr.subs(second).subs(first).subs(coordinates)


def to_functions(expr: sp.Expr | sp.Matrix) -> sp.Expr | sp.Matrix:
    """Inverse of :func:`to_symbols` for q and dq: makes an expression differentiable in time."""
    return expr.subs({dqi: qi.diff(t) for qi, dqi in zip(q_t, dq)}).subs(dict(zip(q, q_t)))


# Section 2.2, orientation.
def euler_rotation(phi: sp.Expr, theta: sp.Expr, psi: sp.Expr) -> sp.Matrix:
    """The paper's ``Reuler``: ``R = R_psi R_theta R_phi`` (spin about x, lean about y, heading about z)."""
    r_phi = sp.Matrix([[1, 0, 0], [0, sp.cos(phi), -sp.sin(phi)], [0, sp.sin(phi), sp.cos(phi)]])
    r_theta = sp.Matrix([[sp.cos(theta), 0, sp.sin(theta)], [0, 1, 0], [-sp.sin(theta), 0, sp.cos(theta)]])
    r_psi = sp.Matrix([[sp.cos(psi), -sp.sin(psi), 0], [sp.sin(psi), sp.cos(psi), 0], [0, 0, 1]])
    return r_psi * r_theta * r_phi


def body_angular_velocity(rotation: sp.Matrix) -> sp.Matrix:
    """The paper's ``wr``: the rotation vector in the body frame, from ``R^T dR/dt`` (rad/s)."""
    skew = rotation.T * rotation.diff(t)
    return sp.Matrix([-skew[1, 2], skew[0, 2], -skew[0, 1]])


@dataclass(frozen=True)
class Derivation:
    """Every intermediate result of the derivation, as expressions in the plain symbols of this module.

    Attributes:
        rotation: ``R(phi, theta, psi)``, body to world.
        omega_body: angular velocity in the body frame, ``omega_r`` (rad/s).
        omega_world: angular velocity in the world frame, ``R omega_r`` (rad/s).
        centre: the disk's centre ``(c1, c2, r cos(theta))`` (m).
        kinetic_energy: ``E_K`` (J).
        potential_energy: ``E_p`` (J).
        lagrangian: ``L = E_K - E_p`` (J).
        euler_lagrange: ``Q(q, dq, ddq) = d/dt dL/ddq - dL/dq`` (5 rows).
        constraint_matrix: ``A(q)``, the rolling constraints being ``A(q) dq = 0`` (2 x 5).
        constraint_forces: ``tau(q, lambda) = A^T lambda``, the d'Alembert generalized constraint forces.
        torque_forces: ``Q_torque = J_omega^T T``, the generalized forces of the input torques.
        mass_matrix: ``M(q)``, with ``M (lambda, ddq) = b`` (7 x 7).
        rhs: ``b(q, dq, u)`` (7 rows).
        multipliers_free: ``lambda`` with zero torque (N; the horizontal ground reaction).
        multipliers_input: ``d lambda / d u`` (2 x 2).
        accelerations_free: ``ddq`` with zero torque, ``f(q, dq)`` (5 rows).
        accelerations_input: ``B(q) = d ddq / d u`` (5 x 2).
        normal_force_free: the vertical ground reaction ``N = m (g + c3'')`` with zero torque (N), ``c3 = r cos(theta)``
            the centre's height, written with the model's accelerations: a function of ``(theta, dphi, dtheta,
            dpsi)``.
        normal_force_input: ``d N / d u`` (1 x 2); zero, as the torques do not reach ``ddtheta``.
    """

    rotation: sp.Matrix
    omega_body: sp.Matrix
    omega_world: sp.Matrix
    centre: sp.Matrix
    kinetic_energy: sp.Expr
    potential_energy: sp.Expr
    lagrangian: sp.Expr
    euler_lagrange: sp.Matrix
    constraint_matrix: sp.Matrix
    constraint_forces: sp.Matrix
    torque_forces: sp.Matrix
    mass_matrix: sp.Matrix
    rhs: sp.Matrix
    multipliers_free: sp.Matrix
    multipliers_input: sp.Matrix
    accelerations_free: sp.Matrix
    accelerations_input: sp.Matrix
    normal_force_free: sp.Expr
    normal_force_input: sp.Matrix

    @property
    def multipliers(self) -> sp.Matrix:
        """``lambda(q, dq, u)``, the contact forces (N)."""
        return self.multipliers_free + self.multipliers_input * torques

    @property
    def accelerations(self) -> sp.Matrix:
        """``ddq(q, dq, u) = f + B u``."""
        return self.accelerations_free + self.accelerations_input * torques

    @property
    def normal_force(self) -> sp.Expr:
        """``N(q, dq, u) = N_free + N_input u``, the vertical ground reaction on the disk (N)."""
        return self.normal_force_free + (self.normal_force_input * torques)[0]


def _simplify(matrix: sp.Matrix) -> sp.Matrix:
    """Each entry of a solution of the linear system, simplified. The entries are rational functions of sines and
    cosines: cancelling their common factors first (a polynomial gcd, quick) leaves trigsimp a smaller expression and
    gives the same 21 entries (:func:`derive` took 42.7 s without it, 30.2 s with it, on a 2-core AMD EPYC)."""
    return matrix.applyfunc(lambda expr: sp.simplify(sp.factor_terms(sp.trigsimp(sp.cancel(expr)))))


@functools.cache
def derive() -> Derivation:
    """Runs the whole derivation (a few seconds); the result is cached."""
    # Section 2.2: orientation and rotation vector.
    rotation_t = euler_rotation(phi_t, theta_t, psi_t)
    omega_body_t = sp.simplify(body_angular_velocity(rotation_t))
    omega_world_t = sp.simplify(rotation_t * omega_body_t)

    # Section 2.3: Lagrangian of a thin uniform disk whose lowest point touches the plane z = 0.
    centre_t = sp.Matrix([c1_t, c2_t, r * sp.cos(theta_t)])
    inertia = sp.diag(m * r**2 / 2, m * r**2 / 4, m * r**2 / 4)
    kinetic_t = m * centre_t.diff(t).dot(centre_t.diff(t)) / 2 + omega_body_t.dot(inertia * omega_body_t) / 2
    potential_t = m * g * centre_t[2]
    lagrangian_t = kinetic_t - potential_t
    dq_t = q_t.diff(t)
    euler_lagrange_t = sp.Matrix([lagrangian_t]).jacobian(dq_t).diff(t) - sp.Matrix([lagrangian_t]).jacobian(q_t)
    euler_lagrange = sp.simplify(to_symbols(euler_lagrange_t.T))

    # Section 2.4: non-holonomic rolling constraints A(q) dq = 0 (the contact point has zero velocity).
    constraint_matrix = sp.Matrix(
        [
            [1, 0, -r * sp.sin(psi), -r * sp.cos(psi) * sp.cos(theta), r * sp.sin(psi) * sp.sin(theta)],
            [0, 1, r * sp.cos(psi), -r * sp.sin(psi) * sp.cos(theta), -r * sp.cos(psi) * sp.sin(theta)],
        ]
    )

    # Section 2.5: d'Alembert. Constraint forces do no work on admissible virtual displacements: tau = A^T lambda.
    constraint_forces = constraint_matrix.T * multipliers

    # Extension: input torques T = tau_spin R e1 + tau_steer e3 (world frame), by virtual power Q = J_omega^T T.
    omega_world = to_symbols(omega_world_t)
    rotation = to_symbols(rotation_t)
    omega_jacobian = omega_world.jacobian(dq)
    torque_world = tau_spin * rotation[:, 0] + tau_steer * sp.Matrix([0, 0, 1])
    torque_forces = sp.simplify(omega_jacobian.T * torque_world)

    # Differentiated constraints d/dt (A dq) = 0, stacked on Q - tau - Q_torque = 0: S = M (lambda, ddq) - b.
    constraint_rate = to_symbols(to_functions(constraint_matrix * dq).diff(t))
    system = sp.Matrix.vstack(constraint_rate, euler_lagrange - constraint_forces - torque_forces)
    unknowns = sp.Matrix.vstack(multipliers, ddq)
    mass_matrix = sp.simplify(system.jacobian(unknowns))
    rhs = sp.simplify(mass_matrix * unknowns - system)

    # (lambda, ddq) = M^-1 b, split into its torque-free part and its input matrix (b is affine in u).
    zero_torque = {tau_spin: 0, tau_steer: 0}
    solution_free = _simplify(mass_matrix.LUsolve(rhs.subs(zero_torque)))
    solution_input = _simplify(mass_matrix.LUsolve(rhs.jacobian(torques)))

    # Extension: the vertical ground reaction. The contact keeps the centre at height c3 = r cos(theta), so Newton's
    # law for the centre along z, m c3'' = N - m g, gives N once c3'' is written with the model's ddtheta.
    height_acceleration = to_symbols(centre_t[2].diff(t, 2))
    accelerations = {ddtheta: solution_free[5] + (solution_input[5, :] * torques)[0]}
    normal_force = sp.expand(m * (g + height_acceleration.subs(accelerations)))
    normal_force_free = sp.simplify(normal_force.subs(zero_torque))
    normal_force_input = sp.Matrix([normal_force]).jacobian(torques).applyfunc(sp.simplify)

    return Derivation(
        rotation=rotation,
        omega_body=to_symbols(omega_body_t),
        omega_world=omega_world,
        centre=to_symbols(centre_t),
        kinetic_energy=sp.simplify(to_symbols(kinetic_t)),
        potential_energy=to_symbols(potential_t),
        lagrangian=sp.simplify(to_symbols(lagrangian_t)),
        euler_lagrange=euler_lagrange,
        constraint_matrix=constraint_matrix,
        constraint_forces=constraint_forces,
        torque_forces=torque_forces,
        mass_matrix=mass_matrix,
        rhs=rhs,
        multipliers_free=solution_free[:2, :],
        multipliers_input=solution_input[:2, :],
        accelerations_free=solution_free[2:, :],
        accelerations_input=solution_input[2:, :],
        normal_force_free=normal_force_free,
        normal_force_input=normal_force_input,
    )


@dataclass(frozen=True)
class SlidingDerivation:
    """The disk that slides: the paper's frozen lake (no rolling constraint) with a horizontal contact force.

    State ``(q, dq) = (c1, c2, phi, theta, psi, dc1, dc2, dphi, dtheta, dpsi)``. Expressions in the plain symbols of
    this module; the contact force is ``N f``, ``f = (f1, f2)`` (:data:`friction_ratio`) being a symbol here, so that
    the one derivation serves kinetic friction, the frozen lake (``f = 0``) and any given contact force.

    Attributes:
        slip_velocity: ``v = A(q) dq``, the horizontal velocity of the disk's material contact point (m/s), with the
            rolling model's constraint rows ``A`` (rolling is ``v = 0``).
        friction_forces: ``Q_F = A^T (N f)``, the generalized force of the contact force, by virtual power:
            ``Q_F . dq = N f . v``.
        vertical_law: ``N - m (g + c3'')``, Newton's law for the centre along z (``c3 = r cos(theta)``), zero.
        mass_matrix: ``M_s(q, f)``, with ``M_s (ddq, N) = b_s`` (6 x 6).
        rhs: ``b_s(q, dq, u)`` (6 rows).
        accelerations: ``ddq(q, dq, u, f)`` (5 rows).
        normal_force: ``N(q, dq, u, f)``, the vertical ground reaction on the disk (N).
        kinetic_friction: Coulomb's kinetic law ``f = -mu v / |v|`` in the symbols ``v1, v2`` (:data:`slip`),
            ``mu`` and ``slip_speed`` (``|v| > 0``); undefined at ``v = 0``.
        energy: kinetic plus potential energy ``E_K + E_p`` with the centre's horizontal velocity free (J).
        slip_acceleration: ``dv/dt = d(A(q) dq)/dt``, in the state and the symbols ``dd<name>`` of its time derivative
            (:data:`ddq` for the accelerations; m/s^2).
        impulse_velocities: ``dq + M^-1 A^T P``, the velocities just after the contact impulse ``P = W^-1 dv``,
            ``W = A M^-1 A^T``, that changes the slip by ``dv`` (symbols :data:`slip_change`): ``M`` the kinetic
            energy's mass matrix ``d^2 E_K / d dq^2``. The impulse acts at the contact point; with ``dv = -v`` it
            zeroes the slip (sticking) and changes the kinetic energy by ``v . P / 2 = -v^T W^-1 v / 2 <= 0``.
        mobility: ``m W``, the slip's response to a horizontal force at the contact point (symmetric, 2 x 2).
    """

    slip_velocity: sp.Matrix
    friction_forces: sp.Matrix
    vertical_law: sp.Expr
    mass_matrix: sp.Matrix
    rhs: sp.Matrix
    accelerations: sp.Matrix
    normal_force: sp.Expr
    kinetic_friction: sp.Matrix
    energy: sp.Expr
    slip_acceleration: sp.Matrix
    impulse_velocities: sp.Matrix
    mobility: sp.Matrix


@functools.cache
def derive_sliding() -> SlidingDerivation:
    """Derives the sliding disk from the rolling derivation's Lagrangian, constraint rows and torques (half a
    minute); the result is cached."""
    rolling = derive()

    # Section 2.3 unchanged: the Lagrangian with c3 = r cos(theta), and its Euler-Lagrange rows Q(q, dq, ddq). The
    # contact keeps the lowest point of the rim on the plane, and that point's vertical velocity is zero whatever dq:
    # the normal force does no virtual work, so it does not appear in Q - Q_torque - Q_F = 0.
    euler_lagrange = rolling.euler_lagrange

    # Section 2.4 read the other way: A(q) dq is the horizontal velocity of the material contact point, the slip.
    slip_velocity = rolling.constraint_matrix * dq

    # Virtual power of the contact force F = N f at the contact point: F . v = (A^T F) . dq, so Q_F = A^T F (the
    # rolling model's constraint forces tau = A^T lambda are the same law with lambda in place of F).
    friction_forces = rolling.constraint_matrix.T * (normal * friction_ratio)

    # Newton's law for the centre along z: m c3'' = N - m g, with c3'' depending on ddtheta.
    height_acceleration = to_symbols(to_functions(rolling.centre[2]).diff(t, 2))
    vertical_law = normal - m * (g + height_acceleration)

    # The five Euler-Lagrange rows with the torques and the contact force, and the vertical law: linear in (ddq, N).
    system = sp.Matrix.vstack(euler_lagrange - rolling.torque_forces - friction_forces, sp.Matrix([vertical_law]))
    unknowns = sp.Matrix.vstack(ddq, sp.Matrix([normal]))
    mass_matrix = sp.simplify(system.jacobian(unknowns))
    rhs = sp.simplify(mass_matrix * unknowns - system)
    solution = mass_matrix.LUsolve(rhs).applyfunc(sp.simplify)

    # Coulomb's kinetic friction: the contact force opposes the slip, with magnitude mu N.
    kinetic_friction = -mu * slip / slip_speed

    # The slip's rate of change, the derivative of A(q) dq along the motion: where a slide will stop.
    slip_acceleration = slip_velocity.jacobian([*q, *dq]) * sp.Matrix([*dq, *ddq])

    # A contact impulse P at the contact point, M (dq+ - dq) = A^T P, changing the slip by dv = A (dq+ - dq) = W P
    # (the normal impulse keeps c3 = r cos(theta) and does no work: it is not in the reduced coordinates q).
    kinetic_mass = sp.hessian(rolling.kinetic_energy, dq).applyfunc(sp.simplify)
    response = kinetic_mass.inv().applyfunc(sp.simplify) * rolling.constraint_matrix.T
    delassus = (rolling.constraint_matrix * response).applyfunc(sp.simplify)
    impulse = delassus.inv().applyfunc(sp.simplify) * slip_change
    impulse_velocities = dq + (response * impulse).applyfunc(sp.simplify)

    return SlidingDerivation(
        slip_velocity=slip_velocity,
        friction_forces=friction_forces,
        vertical_law=vertical_law,
        mass_matrix=mass_matrix,
        rhs=rhs,
        accelerations=solution[:5, :],
        normal_force=solution[5],
        kinetic_friction=kinetic_friction,
        energy=rolling.kinetic_energy + rolling.potential_energy,
        slip_acceleration=slip_acceleration,
        impulse_velocities=impulse_velocities,
        mobility=(m * delassus).applyfunc(sp.simplify),
    )
