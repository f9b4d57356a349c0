"""The rolling disk's equations of motion as numeric functions: full model, reduced lean model, energy, contact force.

All functions accept one state, shape (8,), or a batch, shape (N, 8), in the paper's order
``x = (c1, c2, phi, theta, psi, dphi, dtheta, dpsi)`` (m, rad, rad/s; see :mod:`rolling_disk_env.derivation` for
the frames). Torques are ``(tau_spin, tau_steer)`` in N m: about the disk's symmetry axis and about the vertical.

The equations are singular at ``|theta| = pi/2``, where the disk lies flat and spin and heading are undefined. The
model's domain is ``|theta| < LEAN_LIMIT = pi/2 - LEAN_MARGIN``; a state outside it raises :class:`OutOfDomainError`.

The reduced *lean* model keeps ``y = (theta, dphi, dtheta, dpsi)``: ``c1, c2, phi, psi`` are ignorable (no equation
depends on them but the centre's velocity, which depends on ``psi``), so ``y`` evolves on its own.

The *sliding* model (the paper's frozen lake, with dry friction: :func:`rolling_disk_env.derivation.derive_sliding`)
has no rolling constraint: its state is ``(q, dq)``, ten numbers, :data:`SLIDING_STATE_NAMES`, the centre's
horizontal velocity ``(dc1, dc2)`` (m/s) among them. Its functions take one 10-state or a batch (N, 10).

The functions run on the compiled engine (:mod:`rolling_disk_env.engine`), imported on first call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rolling_disk_env.constants import LEAN_LIMIT, LEAN_MARGIN

STATE_NAMES = ("c1", "c2", "phi", "theta", "psi", "dphi", "dtheta", "dpsi")
LEAN_NAMES = ("theta", "dphi", "dtheta", "dpsi")
LEAN_INDICES = (3, 5, 6, 7)
"""Where the lean state's components sit in the full state."""
SLIDING_STATE_NAMES = ("c1", "c2", "phi", "theta", "psi", "dc1", "dc2", "dphi", "dtheta", "dpsi")
"""The sliding model's state, the paper's ``(q, dq)``."""
ROLLING_INDICES = (0, 1, 2, 3, 4, 7, 8, 9)
"""Where the full (rolling) state's components sit in a sliding state."""


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


def is_number(value) -> bool:
    """Whether ``value`` is a real number: a Python or numpy integer or float, but not a bool."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def number_pair(value, name: str, pair: str = "(low, high)") -> tuple[float, float]:
    """``value`` as two floats if it is a pair of numbers (Python or numpy, not bools); else ``ValueError`` naming
    ``name`` and the ``pair`` expected."""
    items = list(value) if isinstance(value, (tuple, list, np.ndarray)) else None
    if items is None or len(items) != 2 or not all(is_number(item) for item in items):
        raise ValueError(f"{name} must be a {pair} pair of numbers, got {value!r}")
    return float(items[0]), float(items[1])


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
        """Checks each field (a Python or numpy number, not a bool) and stores it as a Python float."""
        for name in ("mass", "radius", "gravity"):
            value = getattr(self, name)
            if not (is_number(value) and math.isfinite(value) and value > 0):
                raise ValueError(f"DiskParams.{name} must be a finite number > 0, got {value!r}")
            object.__setattr__(self, name, float(value))

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


def check_params(params) -> DiskParams:
    """``params`` if it is a :class:`DiskParams`, :data:`DEFAULT_PARAMS` for None; else ``TypeError``."""
    if params is None:
        return DEFAULT_PARAMS
    if not isinstance(params, DiskParams):
        raise TypeError(
            f"params must be a DiskParams, e.g. DiskParams(mass=1.0), or None, got {type(params).__name__}: {params!r}"
        )
    return params


@dataclass(frozen=True)
class Model:
    """A set of state equations.

    Attributes:
        name: ``"full"`` or ``"lean"``.
        names: the state components, in order.
        lean_index: where theta sits in the state.
    """

    name: str
    names: tuple[str, ...]
    lean_index: int

    @property
    def size(self) -> int:
        return len(self.names)


FULL_MODEL = Model("full", STATE_NAMES, lean_index=3)
LEAN_MODEL = Model("lean", LEAN_NAMES, lean_index=0)
MODELS = {model.name: model for model in (FULL_MODEL, LEAN_MODEL)}
"""The rolling models, by the name ``simulate``'s ``model`` argument takes."""
SLIDING_MODEL = Model("sliding", SLIDING_STATE_NAMES, lean_index=3)


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
    """Validates ``torque``: None (zero), (2,) or, for a batch of N states, (N, 2); returns float64 rows, shape
    (N, 2) (N = 1 for one state)."""
    rows = 1 if batch is None else batch
    if torque is None:
        return np.zeros((rows, 2))
    array = np.asarray(torque, dtype=np.float64)
    valid = array.shape == (2,) or (batch is not None and array.shape == (batch, 2))
    if not valid:
        expected = "(2,)" if batch is None else f"(2,) or ({batch}, 2)"
        raise ValueError(f"torque must have shape {expected} = [tau_spin, tau_steer] in N m, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"torque must be finite, got {array}")
    return np.ascontiguousarray(np.broadcast_to(array, (rows, 2)))


def disk_rows(params: DiskParams | None, rows: int) -> np.ndarray:
    """The constants ``(m, g, r)`` of ``params`` (checked) repeated in ``rows`` rows, the engine's layout."""
    return np.tile(np.array(check_params(params).constants), (rows, 1))


def _rows(model: Model, state, torque, params: DiskParams | None):
    """The checked arguments of the engine's model loops: rows of states, torques and disk constants."""
    x = check_states(state, model)
    torques = check_torques(torque, None if x.ndim == 1 else x.shape[0])
    rows = np.ascontiguousarray(x.reshape(-1, model.size))
    return x.shape, rows, torques, disk_rows(params, rows.shape[0])


def state_derivative(state, torque=None, params: DiskParams | None = None) -> np.ndarray:
    """dx/dt of the full model (the paper's state equations, with optional torques).

    Args:
        state: shape (8,) or (N, 8).
        torque: None (zero), (2,) or (N, 2): ``[tau_spin, tau_steer]`` in N m.
        params: the disk; default ``DiskParams()``.

    Returns:
        ``(dc1, dc2, dphi, dtheta, dpsi, ddphi, ddtheta, ddpsi)``, same shape as ``state``.
    """
    from rolling_disk_env import engine

    shape, rows, torques, disks = _rows(FULL_MODEL, state, torque, params)
    out = np.empty_like(rows)
    engine.derivatives(rows, torques, disks, out)
    return out.reshape(shape)


def lean_derivative(lean_state, torque=None, params: DiskParams | None = None) -> np.ndarray:
    """dy/dt of the reduced lean model, ``y = (theta, dphi, dtheta, dpsi)``, shape (4,) or (N, 4)."""
    from rolling_disk_env import engine

    shape, rows, torques, disks = _rows(LEAN_MODEL, lean_state, torque, params)
    out = np.empty_like(rows)
    engine.derivatives(rows, torques, disks, out)
    return out.reshape(shape)


def lean_state(state) -> np.ndarray:
    """The lean part ``(theta, dphi, dtheta, dpsi)`` of full states, shape (..., 8) -> (..., 4)."""
    return np.asarray(state, dtype=np.float64)[..., LEAN_INDICES]


def _diagnostics(state, torque, params: DiskParams | None) -> np.ndarray:
    """Energy (J), lambda1, lambda2, normal force (N) and required friction of each state: shape (5,) or (N, 5)."""
    from rolling_disk_env import engine

    shape, rows, torques, disks = _rows(FULL_MODEL, state, torque, params)
    out = np.empty((rows.shape[0], 5))
    engine.diagnostics(rows, torques, disks, out)
    return out[0] if len(shape) == 1 else out


def energy(state, params: DiskParams | None = None) -> float | np.ndarray:
    """Kinetic plus potential energy (J), potential zero at the plane: a float, or shape (N,) for a batch."""
    value = _diagnostics(state, None, params)[..., 0]
    return float(value) if np.ndim(value) == 0 else value


def contact_force(state, torque=None, params: DiskParams | None = None) -> np.ndarray:
    """The multipliers ``(lambda1, lambda2)``: horizontal ground reaction on the disk along world x and y (N).

    Returns:
        shape (2,) or (N, 2).
    """
    return _diagnostics(state, torque, params)[..., 1:3]


def normal_force(state, torque=None, params: DiskParams | None = None) -> float | np.ndarray:
    """The vertical ground reaction on the disk, ``N = m (g + c3'')`` with ``c3 = r cos(theta)`` the centre's height
    (N): a float, or shape (N,) for a batch. The disk stays on the plane only while N > 0."""
    value = _diagnostics(state, torque, params)[..., 3]
    return float(value) if np.ndim(value) == 0 else value


def required_friction(state, torque=None, params: DiskParams | None = None) -> float | np.ndarray:
    """The friction coefficient the contact needs to roll without slipping, ``|lambda| / N`` (dimensionless; inf
    where N <= 0, the disk lifting off): a float, or shape (N,) for a batch. A real contact of friction coefficient
    mu slips where this exceeds mu."""
    value = _diagnostics(state, torque, params)[..., 4]
    return float(value) if np.ndim(value) == 0 else value


def check_friction_coefficient(value) -> float:
    """``value`` as a float if it is a finite number >= 0 (not a bool); else ``ValueError``."""
    if not (is_number(value) and math.isfinite(value) and value >= 0):
        raise ValueError(f"friction_coefficient must be a finite number >= 0, got {value!r}")
    return float(value)


def _sliding_rows(state, torque, friction_coefficient, params: DiskParams | None):
    """The checked arguments of the sliding model's loops: rows of 10-states, torques, coefficients and disks."""
    x = check_states(state, SLIDING_MODEL, "x")
    torques = check_torques(torque, None if x.ndim == 1 else x.shape[0])
    rows = np.ascontiguousarray(x.reshape(-1, SLIDING_MODEL.size))
    frictions = np.full(rows.shape[0], check_friction_coefficient(friction_coefficient))
    return x.shape, rows, torques, frictions, disk_rows(params, rows.shape[0])


def sliding_derivative(x, torque=(0.0, 0.0), friction_coefficient: float = 0.0, params: DiskParams | None = None):
    """dx/dt of the sliding model: the paper's frozen lake, with kinetic Coulomb friction at the contact.

    The contact force is ``F = -mu N v / |v|``, opposing the slip ``v`` (:func:`slip_velocity`), N the normal force;
    at zero slip the kinetic law gives no direction and ``F = 0`` (the Coulomb hybrid of :func:`simulate` decides
    there whether the disk rolls). With ``mu = 0`` (the default) the centre's horizontal velocity never changes.
    The model is well posed for ``mu < sqrt(5) / 2``.

    Args:
        x: shape (10,) or (N, 10), :data:`SLIDING_STATE_NAMES` (m, rad, m/s, rad/s).
        torque: (2,) or (N, 2): ``[tau_spin, tau_steer]`` in N m; None is zero.
        friction_coefficient: mu >= 0 (dimensionless).
        params: the disk; default ``DiskParams()``.

    Returns:
        ``(dc1, dc2, dphi, dtheta, dpsi, ddc1, ddc2, ddphi, ddtheta, ddpsi)``, same shape as ``x``.
    """
    from rolling_disk_env import engine

    shape, rows, torques, frictions, disks = _sliding_rows(x, torque, friction_coefficient, params)
    out = np.empty_like(rows)
    engine.sliding_derivatives(rows, torques, frictions, disks, out)
    return out.reshape(shape)


def _sliding_diagnostics(x, torque, friction_coefficient, params) -> np.ndarray:
    """Energy (J), normal force (N), friction force F1, F2 (N), slip velocity v1, v2 (m/s): (6,) or (N, 6)."""
    from rolling_disk_env import engine

    shape, rows, torques, frictions, disks = _sliding_rows(x, torque, friction_coefficient, params)
    out = np.empty((rows.shape[0], 6))
    engine.sliding_diagnostics(rows, torques, frictions, disks, out)
    return out[0] if len(shape) == 1 else out


def sliding_energy(x, params: DiskParams | None = None) -> float | np.ndarray:
    """Kinetic plus potential energy of sliding states (J), potential zero at the plane: a float, or shape (N,)."""
    value = _sliding_diagnostics(x, None, 0.0, params)[..., 0]
    return float(value) if np.ndim(value) == 0 else value


def sliding_normal_force(
    x, torque=(0.0, 0.0), friction_coefficient: float = 0.0, params: DiskParams | None = None
) -> float | np.ndarray:
    """The vertical ground reaction on a sliding disk, ``N = m (g + c3'')`` (N), under kinetic friction of
    coefficient mu (N depends on it: the friction's moment reaches the lean): a float, or shape (N,)."""
    value = _sliding_diagnostics(x, torque, friction_coefficient, params)[..., 1]
    return float(value) if np.ndim(value) == 0 else value


def friction_force(
    x, torque=(0.0, 0.0), friction_coefficient: float = 0.0, params: DiskParams | None = None
) -> np.ndarray:
    """The kinetic friction force on a sliding disk, ``-mu N v / |v|``, along world x and y (N): (2,) or (N, 2)."""
    return _sliding_diagnostics(x, torque, friction_coefficient, params)[..., 2:4]


def slip_velocity(x, params: DiskParams | None = None) -> np.ndarray:
    """The slip velocity of sliding states: the horizontal velocity of the disk's material contact point, ``A(q) dq``
    with the paper's constraint rows A, along world x and y (m/s): (2,) or (N, 2). Zero is rolling."""
    return _sliding_diagnostics(x, None, 0.0, params)[..., 4:6]


def sliding_state(state, params: DiskParams | None = None) -> np.ndarray:
    """Full (rolling) states ``(c1, c2, phi, theta, psi, dphi, dtheta, dpsi)`` as sliding states: the centre's
    velocity from the rolling constraint, the slip zero. Shape (8,) -> (10,) or (N, 8) -> (N, 10)."""
    x = check_states(state)
    rates = state_derivative(x, None, params)
    out = np.empty((*x.shape[:-1], 10))
    out[..., ROLLING_INDICES] = x
    out[..., 5:7] = rates[..., :2]
    return out


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


def steady_motion(theta: float, dpsi: float, params: DiskParams | None = None) -> float:
    """The spin rate that makes the motion with constant lean ``theta`` and heading rate ``dpsi`` steady.

    A steady motion keeps ``theta``, ``dphi`` and ``dpsi`` constant (``dtheta = 0``, zero torque): the centre moves on
    a circle of radius ``r (dphi - dpsi sin(theta)) / dpsi`` at speed ``r (dphi - dpsi sin(theta))``. With
    ``dtheta = 0``, ``ddphi = ddpsi = 0`` hold by themselves and ``ddtheta = 0`` is the paper's circle condition
    (Case 3), solved for the spin rate:
    ``dphi = 2 g tan(theta) / (3 r dpsi) + 5 dpsi sin(theta) / 6``.

    With ``dpsi = 0`` the condition reads ``4 g sin(theta) / (5 r) = 0``: a leaning disk must turn, and the vertical
    disk rolling straight (``theta = dpsi = 0``) is steady at *every* spin rate. Both raise, as no single spin rate
    answers; :func:`steady_motion_eigenvalues` takes the spin rate of straight rolling as its ``dphi`` argument.

    Args:
        theta: lean (rad), ``|theta| < LEAN_LIMIT``; > 0 with ``dpsi > 0`` leans into a counter-clockwise turn.
        dpsi: heading rate (rad/s), nonzero.
        params: the disk; default ``DiskParams()``.

    Returns:
        ``dphi`` (rad/s).

    Raises:
        OutOfDomainError: ``|theta| >= LEAN_LIMIT``.
        ValueError: ``dpsi = 0``, or a value that is not finite.
    """
    p = check_params(params)
    if not (math.isfinite(theta) and math.isfinite(dpsi)):
        raise ValueError(f"theta and dpsi must be finite, got theta = {theta!r} rad and dpsi = {dpsi!r} rad/s")
    if abs(theta) >= LEAN_LIMIT:
        raise OutOfDomainError(
            f"theta = {theta:.6g} rad is outside the model's domain |theta| < {LEAN_LIMIT:.6g} (pi/2 - {LEAN_MARGIN})",
            theta=theta,
        )
    if dpsi == 0:
        if theta == 0:
            raise ValueError(
                "theta = dpsi = 0 is straight vertical rolling, steady at every spin rate dphi: "
                "there is no spin rate to solve for"
            )
        raise ValueError(f"dpsi must be nonzero for theta = {theta:.6g} rad: a leaning disk is steady only if it turns")
    return 2 * p.gravity * math.tan(theta) / (3 * p.radius * dpsi) + 5 * dpsi * math.sin(theta) / 6


def steady_circle(radius: float, speed: float, params: DiskParams | None = None) -> tuple[float, float, float]:
    """The steady circle whose centre path has ``radius`` (m) at ``speed`` (m/s), turning counter-clockwise.

    With theta and the rates constant, the centre moves at ``v = r (dphi - dpsi sin(theta))`` and turns at ``dpsi``,
    so ``dpsi = v / R``. The paper's circle condition (:func:`steady_motion`) then reads
    ``v / r + dpsi sin(theta) / 6 = 2 g tan(theta) / (3 r dpsi)``, increasing in theta while ``dpsi^2 < 4 g / r``;
    the engine solves it by Newton's method (``engine.steady_circle``, which the circle task's episodes use too).

    Returns:
        ``(theta, dphi, dpsi)``: lean (rad, > 0: leaning into the turn), spin and heading rates (rad/s).

    Raises:
        ValueError: a radius or speed that is not finite and > 0, or a circle too tight to be steady or to stay in
            the model's domain.
    """
    from rolling_disk_env import engine

    p = check_params(params)
    if not (is_number(radius) and is_number(speed) and radius > 0 and speed > 0 and math.isfinite(radius + speed)):
        raise ValueError(f"radius and speed must be finite numbers > 0, got {radius!r} m and {speed!r} m/s")
    dpsi = speed / radius
    if dpsi * dpsi >= 4 * p.gravity / p.radius:
        raise ValueError(
            f"no steady circle of radius {radius} m at {speed} m/s: it turns at dpsi = {dpsi:.3g} rad/s >= "
            f"2 sqrt(g / r) = {2 * math.sqrt(p.gravity / p.radius):.3g} rad/s; raise the radius or lower the speed"
        )
    theta, dphi, dpsi = engine.steady_circle(float(radius), float(speed), p.gravity, p.radius)
    if math.isnan(theta):
        raise ValueError(f"the steady circle of radius {radius} m at {speed} m/s would lean past the model's domain")
    return theta, dphi, dpsi


def lean_jacobians(lean_state, torque=None, params: DiskParams | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The lean model linearized: ``d(dy/dt) = A dy + B du`` about ``y = (theta, dphi, dtheta, dpsi)`` and ``u``.

    From the generated SymPy Jacobians of the lean model.

    Args:
        lean_state: ``y``, shape (4,) (rad, rad/s).
        torque: None (zero) or ``u = [tau_spin, tau_steer]`` (N m), shape (2,).
        params: the disk; default ``DiskParams()``.

    Returns:
        ``A = d(dy/dt)/dy``, shape (4, 4) (rows and columns in the order of ``y``), and ``B = d(dy/dt)/du``, shape
        (4, 2) (columns ``tau_spin``, ``tau_steer``; rad/s^2 per N m in its last three rows).
    """
    y = check_states(lean_state, LEAN_MODEL, "lean_state")
    if y.ndim != 1:
        raise ValueError(f"lean_state must have shape (4,), got {y.shape}")
    from rolling_disk_env._generated import kernels

    u = check_torques(torque, None)[0]
    entries = kernels.lean_jacobians(tuple(y.tolist()), float(u[0]), float(u[1]), *check_params(params).constants)
    jacobians = np.array(entries, dtype=np.float64)
    return jacobians[:16].reshape(4, 4), jacobians[16:].reshape(4, 2)


def steady_motion_eigenvalues(
    theta: float, dpsi: float, params: DiskParams | None = None, *, dphi: float | None = None
) -> np.ndarray:
    """The eigenvalues of the lean model linearized about the steady motion ``(theta, steady_motion(theta, dpsi),
    0, dpsi)``, zero torque (1/s).

    Steady motions form a two-parameter family of equilibria of the lean model, so two eigenvalues are zero (up to
    round-off); the other two are ``+-sqrt(k)``. The disk conserves energy: a steady motion is stable when ``k < 0``
    (a purely imaginary pair: the lean oscillates about it) and unstable when ``k > 0``. Numerically, real parts
    within a small tolerance of zero (about 1e-7 of the largest eigenvalue's size) mean stable.

    Args:
        theta: lean (rad), ``|theta| < LEAN_LIMIT``.
        dpsi: heading rate (rad/s).
        params: the disk; default ``DiskParams()``.
        dphi: the spin rate (rad/s) of straight vertical rolling, ``theta = dpsi = 0``, which is steady at every spin
            rate; required there and only there (elsewhere :func:`steady_motion` gives it).

    Returns:
        4 complex eigenvalues, shape (4,), sorted by decreasing real part.

    Raises:
        OutOfDomainError: ``|theta| >= LEAN_LIMIT``.
        ValueError: no steady motion (``dpsi = 0``, ``theta != 0``), or ``dphi`` missing or superfluous.
    """
    straight = theta == 0 and dpsi == 0
    if straight and dphi is None:
        raise ValueError("theta = dpsi = 0 is straight vertical rolling, steady at every spin rate: pass its dphi")
    if not straight and dphi is not None:
        raise ValueError(
            f"dphi is only for straight vertical rolling (theta = dpsi = 0); at theta = {theta!r} rad and "
            f"dpsi = {dpsi!r} rad/s the steady spin rate is steady_motion(theta, dpsi)"
        )
    spin = dphi if straight else steady_motion(theta, dpsi, params)
    a, _ = lean_jacobians((theta, spin, 0.0, dpsi), params=params)
    eigenvalues = np.linalg.eigvals(a)
    return eigenvalues[np.argsort(-eigenvalues.real, kind="stable")]
