"""The integrators and :func:`simulate`.

Methods (:data:`METHODS`), all but the last integrated by the compiled engine (:mod:`rolling_disk_env.engine`), one
step of each written out from its Butcher tableau by :mod:`rolling_disk_env.codegen`:

* ``"euler"``: explicit Euler, order 1, one evaluation per step. Its energy grows: use it to see why not.
* ``"symplectic_euler"``: semi-implicit Euler, order 1, two evaluations: velocities first, then coordinates from the
  new velocities. The rolling constraint is nonholonomic, so it has no symplectic advantage here.
* ``"rk4"``: the classical fourth-order Runge-Kutta method, four evaluations.
* ``"dopri5"``: Dormand-Prince 5(4) with error control: each interval is integrated in as many steps as the
  tolerances ``rtol`` and ``atol`` need (seven evaluations each), from the last accepted step size; it gives up, with
  :class:`OutOfDomainError`, after ``engine.MAX_ADAPTIVE_SUBSTEPS`` steps in one interval.
* ``"dop853"``: scipy's adaptive Dormand-Prince 8(5,3) on the engine's derivative, the accuracy reference.
"""

from __future__ import annotations

import math

import numpy as np

from rolling_disk_env.dynamics import (
    LEAN_LIMIT,
    LEAN_MODEL,
    MODELS,
    DiskParams,
    Model,
    OutOfDomainError,
    check_states,
    check_torques,
    disk_rows,
    is_number,
)

ENGINE_METHODS = ("euler", "symplectic_euler", "rk4", "dopri5")
"""The methods the compiled engine integrates (their index is the engine's code for them)."""
METHODS = (*ENGINE_METHODS, "dop853")
EVALUATIONS_PER_STEP = {"euler": 1, "symplectic_euler": 2, "rk4": 4}
"""Derivative evaluations per step of the fixed-step methods (the cost unit of the benchmarks)."""


class RollingContactError(OutOfDomainError):
    """The contact stopped rolling without slipping: the disk slipped or lifted off the plane.

    Attributes:
        time: simulation time (s).
        reason: ``"slipped"`` (the contact needs more friction than ``friction_coefficient``) or ``"lifted_off"``
            (the normal force vanished).
        required_friction: ``|lambda| / N`` there (inf once N <= 0).
        normal_force: N (N).
    """

    def __init__(self, message: str, time: float, reason: str, required_friction: float, normal_force: float):
        super().__init__(message, time=time)
        self.reason = reason
        self.required_friction = required_friction
        self.normal_force = normal_force


def _domain_error(time: float, theta) -> OutOfDomainError:
    theta = np.atleast_1d(np.asarray(theta, dtype=np.float64))
    if not np.all(np.isfinite(theta)):
        return OutOfDomainError(
            f"the state stopped being finite at t = {time:.6g} s: the integrator diverged (reduce dt)", time=time
        )
    worst = float(theta[np.argmax(np.abs(theta))])
    return OutOfDomainError(
        f"lean theta = {worst:.6g} rad at t = {time:.6g} s left the model's domain |theta| < {LEAN_LIMIT:.6g} rad "
        "(the disk has fallen flat, where the equations are singular)",
        time=time,
        theta=worst,
    )


def _contact_check(system: Model, rows: np.ndarray, torques, disks, friction: float, time: float) -> None:
    """Raises :class:`RollingContactError` if a disk has lifted off, or slipped under ``friction``."""
    from rolling_disk_env import engine

    full = rows
    if system is LEAN_MODEL:  # |lambda| and N depend on the lean state only
        full = np.zeros((rows.shape[0], 8))
        full[:, [3, 5, 6, 7]] = rows
    values = np.empty((rows.shape[0], 5))
    engine.diagnostics(full, torques, disks, values)
    normal, required = values[:, 3], values[:, 4]
    lifted = np.flatnonzero(~(normal > 0))
    slipped = np.flatnonzero(required > friction)
    if lifted.size or slipped.size:
        i = int(lifted[0] if lifted.size else slipped[0])
        reason = "lifted_off" if lifted.size else "slipped"
        cause = (
            "the normal force vanished: the disk lifted off the plane"
            if lifted.size
            else f"the contact needs a friction coefficient of {required[i]:.6g} > friction_coefficient = {friction}"
        )
        raise RollingContactError(
            f"at t = {time:.6g} s {cause} (N = {normal[i]:.6g} N, required friction |lambda| / N = {required[i]:.6g})",
            time=time,
            reason=reason,
            required_friction=float(required[i]),
            normal_force=float(normal[i]),
        )


def _output_times(duration: float, dt: float) -> np.ndarray:
    if not (is_number(duration) and math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a finite number > 0 (s), got {duration!r}")
    if not (is_number(dt) and math.isfinite(dt) and 0 < dt <= duration):
        raise ValueError(f"dt must be a finite number in (0, duration = {duration}] (s), got {dt!r}")
    steps = math.ceil(duration / dt - 1e-9)
    times = np.arange(steps + 1) * dt
    times[-1] = duration
    return times


def simulate(
    state0,
    duration: float,
    dt: float,
    method: str = "rk4",
    torque=None,
    params: DiskParams | None = None,
    model: str = "full",
    rtol: float = 1e-10,
    atol: float = 1e-10,
    friction_coefficient: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Integrates the rolling disk from ``state0`` for ``duration`` seconds.

    Args:
        state0: initial state, shape (size,) for one disk or (N, size) for N disks at once; size 8 for the full
            model, 4 for the lean model ``(theta, dphi, dtheta, dpsi)``.
        duration: simulated time, s.
        dt: step of the fixed-step methods and spacing of the output times, s. The last step is shortened to end
            exactly at ``duration``.
        method: one of :data:`METHODS`.
        torque: None (zero), a constant ``[tau_spin, tau_steer]`` (N m) of shape (2,) or (N, 2), or a callable
            ``torque(t, state)`` returning one; it is sampled at the start of each output interval and held over it
            (with ``"dop853"``, it is called at every evaluation).
        params: the disk; default ``DiskParams()``.
        model: ``"full"`` or ``"lean"`` (the reduced model, with c1, c2, phi and psi left out).
        rtol: relative tolerance of ``"dopri5"`` and ``"dop853"``.
        atol: absolute tolerance of ``"dopri5"`` and ``"dop853"``.
        friction_coefficient: if set, the contact's friction coefficient mu: the simulation stops with
            :class:`RollingContactError` at the first output time where the contact needs more
            (``required_friction > mu``). It always stops where the normal force vanishes (lift-off).

    Returns:
        ``(times, states)``: times of shape (T,) from 0 to ``duration``, states of shape (T, size) or (T, N, size).

    Raises:
        ValueError: a bad argument (shape, finiteness, unknown method or model).
        OutOfDomainError: the lean reaches ``LEAN_LIMIT``, the state stops being finite or ``"dopri5"`` gives up;
            names the time and theta.
        RollingContactError: (an ``OutOfDomainError``) the disk slipped or lifted off; names the time, the required
            friction and the normal force.
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {sorted(MODELS)}, got {model!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (is_number(value) and 0 < value < 1):
            raise ValueError(f"{name} must be a number in (0, 1), got {value!r}")
    if friction_coefficient is not None and not (is_number(friction_coefficient) and friction_coefficient > 0):
        raise ValueError(f"friction_coefficient must be None or a number > 0, got {friction_coefficient!r}")
    friction = math.inf if friction_coefficient is None else float(friction_coefficient)
    system = MODELS[model]
    x0 = check_states(state0, system, name="state0")
    times = _output_times(duration, dt)
    batch = None if x0.ndim == 1 else x0.shape[0]
    rows = np.ascontiguousarray(x0.reshape(-1, system.size))
    disks = disk_rows(params, rows.shape[0])
    if callable(torque):
        policy = torque

        def torque_at(time: float, x: np.ndarray) -> np.ndarray:
            return check_torques(policy(time, x.reshape(x0.shape)), batch)
    else:
        constant = check_torques(torque, batch)

        def torque_at(_time: float, _x: np.ndarray) -> np.ndarray:
            return constant

    if method == "dop853":
        states = _simulate_dop853(system, rows, times, torque_at, disks, rtol, atol, friction)
    else:
        states = _simulate_engine(
            system, ENGINE_METHODS.index(method), rows, times, torque_at, disks, rtol, atol, friction
        )
    return times, states.reshape(len(times), *x0.shape)


def _simulate_engine(system: Model, method: int, rows, times, torque_at, disks, rtol, atol, friction) -> np.ndarray:
    from rolling_disk_env import engine

    states = np.empty((len(times), *rows.shape))
    states[0] = rows
    x = rows.copy()
    sizes = np.full(len(x), times[1] - times[0])
    status = np.zeros(len(x), dtype=np.int8)
    for i in range(1, len(times)):
        torques = torque_at(times[i - 1], x)
        if i == 1:
            _contact_check(system, x, torques, disks, friction, times[0])
        engine.advance(method, x, torques, disks, times[i] - times[i - 1], sizes, rtol, atol, status)
        if status.any():
            if (status == engine.SUBSTEP_LIMIT).any():
                raise OutOfDomainError(
                    f"dopri5 did not reach t = {times[i]:.6g} s in {engine.MAX_ADAPTIVE_SUBSTEPS} steps under "
                    f"rtol = {rtol}, atol = {atol}: loosen the tolerances or reduce dt",
                    time=times[i],
                )
            raise _domain_error(times[i], x[:, system.lean_index])
        _contact_check(system, x, torques, disks, friction, times[i])
        states[i] = x
    return states


def _simulate_dop853(system: Model, rows, times, torque_at, disks, rtol, atol, friction) -> np.ndarray:
    try:
        from scipy.integrate import solve_ivp
    except ImportError as error:
        raise ImportError(
            f'method "dop853" needs scipy: pip install scipy, or "rolling-disk-env[paper]" ({error})'
        ) from error

    from rolling_disk_env import engine

    shape = rows.shape

    def rhs(time, flat):
        x = flat.reshape(shape)
        out = np.empty(shape)
        engine.derivatives(x, torque_at(time, x), disks, out)
        return out.ravel()

    def leaves_domain(_time, flat):
        return LEAN_LIMIT - np.max(np.abs(flat.reshape(shape)[:, system.lean_index]))

    leaves_domain.terminal = True
    with np.errstate(all="ignore"):
        solution = solve_ivp(
            rhs,
            (times[0], times[-1]),
            rows.ravel(),
            method="DOP853",
            t_eval=times,
            events=leaves_domain,
            rtol=rtol,
            atol=atol,
        )
    if solution.status == 1:
        time = float(solution.t_events[0][0])
        raise _domain_error(time, solution.y_events[0][0].reshape(shape)[:, system.lean_index])
    if solution.status != 0 or not np.all(np.isfinite(solution.y)):
        raise _domain_error(float(solution.t[-1]), math.nan)
    states = solution.y.T.reshape(len(times), *shape)
    for time, x in zip(times, states):
        _contact_check(system, np.ascontiguousarray(x), torque_at(time, x), disks, friction, time)
    return states
