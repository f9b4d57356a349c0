"""The rolling disk's equations of motion as numeric functions: full model, reduced lean model, energy, contact force.

All functions accept one state, shape (8,), or a batch, shape (N, 8), in the paper's order
``x = (c1, c2, phi, theta, psi, dphi, dtheta, dpsi)`` (m, rad, rad/s; see :mod:`rolling_disk_env.derivation` for
the frames). Torques are ``(tau_spin, tau_steer)`` in N m: about the disk's symmetry axis and about the vertical.

The equations are singular at ``|theta| = pi/2``, where the disk lies flat and spin and heading are undefined. The
model's domain is ``|theta| < LEAN_LIMIT = pi/2 - LEAN_MARGIN``; a state outside it raises :class:`OutOfDomainError`.

The reduced *lean* model keeps ``y = (theta, dphi, dtheta, dpsi)``: ``c1, c2, phi, psi`` are ignorable (no equation
depends on them but the centre's velocity, which depends on ``psi``), so ``y`` evolves on its own.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rolling_disk_env._generated import batched, scalar

STATE_NAMES = ("c1", "c2", "phi", "theta", "psi", "dphi", "dtheta", "dpsi")
LEAN_NAMES = ("theta", "dphi", "dtheta", "dpsi")
LEAN_INDICES = (3, 5, 6, 7)
"""Where the lean state's components sit in the full state."""

LEAN_MARGIN = 0.01
"""rad. How far from the flat disk (|theta| = pi/2) the model's domain stops: there 1/cos(theta) = 100."""
LEAN_LIMIT = math.pi / 2 - LEAN_MARGIN
"""rad. The model's domain is |theta| < LEAN_LIMIT."""


class OutOfDomainError(ValueError):
    """A state left the model's domain: the lean reached ``LEAN_LIMIT`` or a value stopped being finite.

    Attributes:
        time: simulation time (s) at which it happened, or None for a state given as input.
        theta: the offending lean (rad), or NaN if the state was not finite.
    """

    def __init__(self, message: str, time: float | None = None, theta: float = math.nan):
        super().__init__(message)
        self.time = time
        self.theta = theta


@dataclass(frozen=True)
class DiskParams:
    """A thin uniform disk rolling on a horizontal plane.

    Attributes:
        mass: m, kg.
        radius: r, m.
        gravity: g, m/s^2.
    """

    mass: float = 5.0
    radius: float = 1.0
    gravity: float = 9.81

    def __post_init__(self) -> None:
        for name in ("mass", "radius", "gravity"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"DiskParams.{name} must be a finite number > 0, got {value!r}")

    @property
    def constants(self) -> tuple[float, float, float]:
        """``(m, g, r)``, the argument order of the generated code."""
        return (float(self.mass), float(self.gravity), float(self.radius))

    @property
    def axial_inertia(self) -> float:
        """Moment of inertia about the symmetry axis, ``m r^2 / 2`` (kg m^2)."""
        return self.mass * self.radius**2 / 2

    @property
    def diametral_inertia(self) -> float:
        """Moment of inertia about a diameter, ``m r^2 / 4`` (kg m^2)."""
        return self.mass * self.radius**2 / 4

    @property
    def critical_spin_rate(self) -> float:
        """``sqrt(g / (3 r))`` (rad/s): upright rolling is stable iff ``dphi^2 > g / (3 r)``."""
        return math.sqrt(self.gravity / (3 * self.radius))


DEFAULT_PARAMS = DiskParams()


@dataclass(frozen=True)
class Model:
    """A set of state equations, in the generated code's calling convention.

    Attributes:
        name: ``"full"`` or ``"lean"``.
        names: the state components, in order.
        scalar: ``f(x, k, h, tau_spin, tau_steer, m, g, r)``, dx/dt at ``x + h k`` for one disk (floats).
        batched: the same for component-major arrays of shape (size, N), writing into a last argument ``out``.
        scalar_rk4: ``step(x, dt, tau_spin, tau_steer, m, g, r)``, one RK4 step of one disk with the four stages
            written out: the arithmetic of ``integrators.rk4`` on ``scalar``, to the last bit, in less time.
        lean_index: where theta sits in the state.
    """

    name: str
    names: tuple[str, ...]
    scalar: Callable
    batched: Callable
    scalar_rk4: Callable
    lean_index: int

    @property
    def size(self) -> int:
        return len(self.names)


FULL_MODEL = Model(
    "full", STATE_NAMES, scalar.state_derivative, batched.state_derivative, scalar.state_rk4_step, lean_index=3
)
LEAN_MODEL = Model(
    "lean", LEAN_NAMES, scalar.lean_derivative, batched.lean_derivative, scalar.lean_rk4_step, lean_index=0
)
MODELS = {model.name: model for model in (FULL_MODEL, LEAN_MODEL)}


def check_states(state, model: Model = FULL_MODEL, name: str = "state") -> np.ndarray:
    """Validates one state (size,) or a batch (N, size) of ``model``: float64, finite, inside the lean domain.

    Raises:
        ValueError: wrong shape or non-finite values.
        OutOfDomainError: ``|theta| >= LEAN_LIMIT``.
    """
    array = np.asarray(state, dtype=np.float64)
    size = model.size
    if array.ndim not in (1, 2) or array.shape[-1] != size:
        raise ValueError(f"{name} must have shape ({size},) or (N, {size}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array}")
    theta = array[..., model.lean_index]
    if np.any(np.abs(theta) >= LEAN_LIMIT):
        worst = float(np.max(np.abs(theta)))
        raise OutOfDomainError(
            f"{name} has lean |theta| = {worst:.6g} rad, outside the model's domain |theta| < {LEAN_LIMIT:.6g} "
            f"(pi/2 - {LEAN_MARGIN}): the disk lies flat and the equations are singular",
            theta=worst,
        )
    return array


def check_torques(torque, batch: int | None) -> np.ndarray:
    """Validates ``torque``: None (zero), (2,) or, for a batch of N states, (N, 2); returns float64, shape (2, N)."""
    if torque is None:
        return np.zeros((2, 1 if batch is None else batch))
    array = np.asarray(torque, dtype=np.float64)
    valid = array.shape == (2,) or (batch is not None and array.shape == (batch, 2))
    if not valid:
        expected = "(2,)" if batch is None else f"(2,) or ({batch}, 2)"
        raise ValueError(f"torque must have shape {expected} = [tau_spin, tau_steer] in N m, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"torque must be finite, got {array}")
    return np.broadcast_to(array, (1 if batch is None else batch, 2)).T


def _evaluate(model: Model, state, torque, params: DiskParams | None) -> np.ndarray:
    x = check_states(state, model)
    batch = None if x.ndim == 1 else x.shape[0]
    u = check_torques(torque, batch)
    rows = x.reshape(-1, model.size)
    out = np.empty_like(rows)
    model.batched(rows.T, rows.T, 0.0, u[0], u[1], *(params or DEFAULT_PARAMS).constants, out.T)
    return out.reshape(x.shape)


def state_derivative(state, torque=None, params: DiskParams | None = None) -> np.ndarray:
    """dx/dt of the full model (the paper's state equations, with optional torques).

    Args:
        state: shape (8,) or (N, 8).
        torque: None (zero), (2,) or (N, 2): ``[tau_spin, tau_steer]`` in N m.
        params: the disk; default ``DiskParams()``.

    Returns:
        ``(dc1, dc2, dphi, dtheta, dpsi, ddphi, ddtheta, ddpsi)``, same shape as ``state``.
    """
    return _evaluate(FULL_MODEL, state, torque, params)


def lean_derivative(lean_state, torque=None, params: DiskParams | None = None) -> np.ndarray:
    """dy/dt of the reduced lean model, ``y = (theta, dphi, dtheta, dpsi)``, shape (4,) or (N, 4)."""
    return _evaluate(LEAN_MODEL, lean_state, torque, params)


def lean_state(state) -> np.ndarray:
    """The lean part ``(theta, dphi, dtheta, dpsi)`` of full states, shape (..., 8) -> (..., 4)."""
    return np.asarray(state, dtype=np.float64)[..., LEAN_INDICES]


def _diagnostics(state, torque, params: DiskParams | None) -> tuple[np.ndarray, np.ndarray]:
    x = check_states(state)
    batch = None if x.ndim == 1 else x.shape[0]
    u = check_torques(torque, batch)
    rows = x.reshape(-1, 8)
    out = np.empty((3, rows.shape[0]))
    batched.diagnostics(rows.T, u[0], u[1], *(params or DEFAULT_PARAMS).constants, out)
    return (out[0, 0], out[1:, 0]) if batch is None else (out[0], out[1:].T)


def energy(state, params: DiskParams | None = None) -> float | np.ndarray:
    """Kinetic plus potential energy (J), potential zero at the plane: a float, or shape (N,) for a batch."""
    value = _diagnostics(state, None, params)[0]
    return float(value) if np.ndim(value) == 0 else value


def contact_force(state, torque=None, params: DiskParams | None = None) -> np.ndarray:
    """The multipliers ``(lambda1, lambda2)``: horizontal ground reaction on the disk along world x and y (N).

    Returns:
        shape (2,) or (N, 2).
    """
    return _diagnostics(state, torque, params)[1]


def rotation_matrix(phi: float, theta: float, psi: float) -> np.ndarray:
    """The paper's orientation ``R = R_psi R_theta R_phi`` (body to world), shape (3, 3); ``R e1`` is the disk's
    axis, ``R e2`` and ``R e3`` span its plane."""
    cf, sf, ct, st, cs, ss = (
        math.cos(phi),
        math.sin(phi),
        math.cos(theta),
        math.sin(theta),
        math.cos(psi),
        math.sin(psi),
    )
    return np.array(
        [
            [ct * cs, -cf * ss + st * cs * sf, ss * sf + st * cs * cf],
            [ct * ss, cs * cf + st * ss * sf, -cs * sf + st * cf * ss],
            [-st, ct * sf, ct * cf],
        ]
    )


def steady_circle_spin_rate(theta: float, dpsi: float, params: DiskParams | None = None) -> float:
    """The paper's circle condition (Case 3): the spin rate that keeps ``theta`` constant at heading rate ``dpsi``.

    ``dphi = 2 g tan(theta) / (3 r dpsi) + 5 dpsi sin(theta) / 6`` (rad/s); the centre then moves on a circle.
    """
    p = params or DEFAULT_PARAMS
    if dpsi == 0:
        raise ValueError("dpsi must be nonzero: a steady circle turns")
    return 2 * p.gravity * math.tan(theta) / (3 * p.radius * dpsi) + 5 * dpsi * math.sin(theta) / 6


def steady_circle(radius: float, speed: float, params: DiskParams | None = None) -> tuple[float, float, float]:
    """The steady circle whose centre path has ``radius`` (m) at ``speed`` (m/s), turning counter-clockwise.

    With theta and the rates constant, the centre moves at ``v = r (dphi - dpsi sin(theta))`` and turns at ``dpsi``,
    so ``dpsi = v / R``. The paper's circle condition (:func:`steady_circle_spin_rate`) then reads
    ``v / r + dpsi sin(theta) / 6 = 2 g tan(theta) / (3 r dpsi)``, increasing in theta while ``dpsi^2 < 4 g / r``;
    it is solved by Newton's method (:func:`steady_circles` solves many at once).

    Returns:
        ``(theta, dphi, dpsi)``: lean (rad, > 0: leaning into the turn), spin and heading rates (rad/s).
    """
    p = params or DEFAULT_PARAMS
    theta, dphi, dpsi = steady_circles(radius, speed, p.gravity, p.radius)
    return float(theta), float(dphi), float(dpsi)


def steady_circles(radius, speed, gravity, disk_radius) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`steady_circle` for arrays: path radius (m), speed (m/s), gravity (m/s^2) and disk radius (m) are floats
    or arrays, broadcast together; returns the arrays ``(theta, dphi, dpsi)``. Each circle takes the Newton steps
    it would take alone, so the results equal those of :func:`steady_circle` one by one.

    Raises:
        ValueError: a radius or speed that is not finite and > 0, or a circle too tight to be steady or to stay in
            the model's domain.
    """
    radius, speed, gravity, disk_radius = np.broadcast_arrays(
        *(np.asarray(v, dtype=np.float64) for v in (radius, speed, gravity, disk_radius))
    )
    bad = ~(np.isfinite(radius) & (radius > 0) & np.isfinite(speed) & (speed > 0))
    if bad.any():
        i = np.flatnonzero(bad)[0]
        raise ValueError(f"radius and speed must be finite and > 0, got {radius.flat[i]} m and {speed.flat[i]} m/s")
    dpsi = speed / radius
    too_tight = dpsi * dpsi >= 4 * gravity / disk_radius
    if too_tight.any():
        i = np.flatnonzero(too_tight)[0]
        raise ValueError(
            f"no steady circle turns at dpsi = {dpsi.flat[i]:.3g} rad/s >= 2 sqrt(g / r): raise the radius"
        )
    a, b, c = 2 * gravity / (3 * disk_radius * dpsi), dpsi / 6, speed / disk_radius
    # excess(theta) = a tan(theta) - b sin(theta) - c is increasing and convex on [0, pi/2), so Newton's method
    # converges monotonically from any point right of the root, such as atan((b + c) / a), where excess >= 0.
    theta = np.arctan((b + c) / a)
    converged = np.zeros(theta.shape, dtype=bool)
    for _ in range(50):
        cos_theta = np.cos(theta)
        step = (a * np.tan(theta) - b * np.sin(theta) - c) / (a / (cos_theta * cos_theta) - b * cos_theta)
        theta = np.where(converged, theta, theta - step)
        converged |= np.abs(step) < 1e-15
        if converged.all():
            break
    too_lean = ~(theta < LEAN_LIMIT)
    if too_lean.any():
        i = np.flatnonzero(too_lean)[0]
        raise ValueError(
            f"the steady circle of radius {radius.flat[i]} m at {speed.flat[i]} m/s would lean past the model's domain"
        )
    return theta, speed / disk_radius + dpsi * np.sin(theta), dpsi
