"""Fixed-step integrators as pure step functions, and :func:`simulate`.

A step function advances one state by ``dt`` seconds: ``step(derivative, x, dt, args) -> x_next``, where
``derivative(x, k, h, *args)`` is a :class:`~rolling_disk_env.dynamics.Model`'s equation evaluated at ``x + h k`` and
``args = (tau_spin, tau_steer, m, g, r)``, the torques held constant over the step. Each method has a scalar form
(``x`` a sequence of floats, one disk; returns a new list) and a batched form
``step(derivative, x, dt, args, work)`` (``x`` a component-major array of shape (size, N), updated in place, ``work``
from :func:`workspace`); both do the same arithmetic, so they agree to round-off.

Methods:

* ``"euler"``: explicit Euler, order 1, one evaluation per step. Its energy grows: use it to see why not.
* ``"symplectic_euler"``: semi-implicit Euler, order 1, two evaluations: velocities first, then coordinates from the
  new velocities. In both models the last three components are the velocities ``(dphi, dtheta, dpsi)``.
* ``"rk4"``: the classical fourth-order Runge-Kutta method, four evaluations.
* ``"dop853"``: scipy's adaptive Dormand-Prince 8(5,3), the accuracy reference; ``dt`` is then the output spacing.
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
import platform
from collections.abc import Callable

import numpy as np

from rolling_disk_env.dynamics import (
    DEFAULT_PARAMS,
    LEAN_LIMIT,
    MODELS,
    DiskParams,
    Model,
    OutOfDomainError,
    check_states,
    check_torques,
)

_VELOCITIES = 3
_M_TRIM_THRESHOLD = -1
"""glibc's mallopt parameter number for the trim threshold."""


def euler(derivative, x, dt, args):
    """Explicit Euler step (scalar)."""
    k = derivative(x, x, 0.0, *args)
    return [a + dt * b for a, b in zip(x, k)]


def symplectic_euler(derivative, x, dt, args):
    """Semi-implicit Euler step (scalar): v' = v + dt a(q, v), then q' = q + dt dq/dt(q, v')."""
    split = len(x) - _VELOCITIES
    k = derivative(x, x, 0.0, *args)
    kick = [0.0] * split + list(k[split:])
    drift = derivative(x, kick, dt, *args)
    return [a + dt * b for a, b in zip(x[:split], drift[:split])] + [a + dt * b for a, b in zip(x[split:], k[split:])]


def rk4(derivative, x, dt, args):
    """Classical Runge-Kutta step (scalar)."""
    half = 0.5 * dt
    k1 = derivative(x, x, 0.0, *args)
    k2 = derivative(x, k1, half, *args)
    k3 = derivative(x, k2, half, *args)
    k4 = derivative(x, k3, dt, *args)
    sixth = dt / 6.0
    return [a + sixth * (b + 2.0 * (c + d) + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4)]


def padded_rows(*shape: int) -> np.ndarray:
    """An uninitialized float64 array of ``shape`` whose last axis is padded by one cache line.

    Component-major states put each component in a row of N floats. When N is a power of two the rows of the
    state, the slopes and the output all start at the same offset modulo the cache's set size and evict each other:
    a right-hand side at N = 4096 then takes 425 us instead of 220 us, depending on where the arrays landed.
    """
    return np.empty((*shape[:-1], shape[-1] + 8))[..., : shape[-1]]


@functools.cache
def retain_freed_heap() -> bool:
    """Asks glibc's malloc to keep up to 64 MiB of freed heap instead of returning it to the OS at once.

    A batched right-hand side makes about 25 numpy temporaries of N floats and frees them; with glibc's default
    (trim above 128 KiB, adjusted dynamically) the heap is trimmed after each call and the next call page-faults
    the memory back in: at N = 4096 an evaluation then takes 430 us instead of 220 us. This sets
    ``M_TRIM_THRESHOLD`` (what the environment variable ``MALLOC_TRIM_THRESHOLD_`` sets, which is left alone if
    the user set it) once per process. Returns whether it was set; elsewhere than glibc it does nothing.
    """
    if "MALLOC_TRIM_THRESHOLD_" in os.environ or platform.libc_ver()[0] != "glibc":
        return False
    try:
        libc = ctypes.CDLL(None)
        return bool(libc.mallopt(_M_TRIM_THRESHOLD, 64 * 2**20))
    except (OSError, AttributeError):
        return False


def workspace(shape: tuple[int, ...]) -> np.ndarray:
    """Scratch memory for the batched steps on states of ``shape`` = (size, N): four slopes.

    Reusing it matters: fresh arrays of this size are page-faulted in on every step, which costs more than the
    arithmetic (measured: 2.8M against 4.7M disk-steps/s for RK4 at N = 4096). For the same reason the first call
    keeps freed heap memory for numpy's temporaries (:func:`retain_freed_heap`).
    """
    retain_freed_heap()
    return padded_rows(4, *shape)


def euler_batched(derivative, x, dt, args, work):
    """Explicit Euler step (batched): updates ``x``, of shape (size, N), in place and returns it."""
    k = derivative(x, x, 0.0, *args, work[0])
    k *= dt
    x += k
    return x


def symplectic_euler_batched(derivative, x, dt, args, work):
    """Semi-implicit Euler step (batched, in place)."""
    split = x.shape[0] - _VELOCITIES
    k = derivative(x, x, 0.0, *args, work[0])
    k[:split] = 0.0
    drift = derivative(x, k, dt, *args, work[1])
    drift[split:] = k[split:]
    drift *= dt
    x += drift
    return x


def rk4_batched(derivative, x, dt, args, work):
    """Classical Runge-Kutta step (batched, in place)."""
    half = 0.5 * dt
    k1 = derivative(x, x, 0.0, *args, work[0])
    k2 = derivative(x, k1, half, *args, work[1])
    k3 = derivative(x, k2, half, *args, work[2])
    k4 = derivative(x, k3, dt, *args, work[3])
    k2 += k3
    k2 *= 2.0
    k2 += k1
    k2 += k4
    k2 *= dt / 6.0
    x += k2
    return x


STEPS: dict[str, tuple[Callable, Callable]] = {
    "euler": (euler, euler_batched),
    "symplectic_euler": (symplectic_euler, symplectic_euler_batched),
    "rk4": (rk4, rk4_batched),
}
"""Fixed-step methods: name -> (scalar step, batched step)."""
EVALUATIONS_PER_STEP = {"euler": 1, "symplectic_euler": 2, "rk4": 4}


def scalar_step(method: str, model: Model) -> Callable:
    """The fastest step of a fixed-step ``method`` for one disk of ``model``: ``step(x, dt, *args) -> x_next``.

    For ``"rk4"`` that is the model's generated step with its stages written out (``model.scalar_rk4``, the same
    arithmetic as :func:`rk4`, about 1.6x faster); the other methods call their step function above.
    """
    if method == "rk4":
        return model.scalar_rk4
    generic, derivative = STEPS[method][0], model.scalar

    def step(x, dt, *args):
        return generic(derivative, x, dt, args)

    return step


METHODS = (*STEPS, "dop853")


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


def _output_times(duration: float, dt: float) -> np.ndarray:
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a finite number > 0 (s), got {duration!r}")
    if not (math.isfinite(dt) and 0 < dt <= duration):
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
) -> tuple[np.ndarray, np.ndarray]:
    """Integrates the rolling disk from ``state0`` for ``duration`` seconds.

    Args:
        state0: initial state, shape (size,) for one disk or (N, size) for N disks at once (the batched path); size 8
            for the full model, 4 for the lean model ``(theta, dphi, dtheta, dpsi)``.
        duration: simulated time, s.
        dt: step of the fixed-step methods and spacing of the output times, s. The last step is shortened to end
            exactly at ``duration``.
        method: one of :data:`METHODS`.
        torque: None (zero), a constant ``[tau_spin, tau_steer]`` (N m) of shape (2,) or (N, 2), or a callable
            ``torque(t, state)`` returning one; it is sampled at the start of each step and held over it (with
            ``"dop853"``, it is called at every evaluation).
        params: the disk; default ``DiskParams()``.
        model: ``"full"`` or ``"lean"`` (the reduced model, with c1, c2, phi and psi left out).
        rtol: relative tolerance of ``"dop853"``.
        atol: absolute tolerance of ``"dop853"``.

    Returns:
        ``(times, states)``: times of shape (T,) from 0 to ``duration``, states of shape (T, size) or (T, N, size).

    Raises:
        ValueError: a bad argument (shape, finiteness, unknown method or model).
        OutOfDomainError: the lean reaches ``LEAN_LIMIT`` or the state stops being finite; names the time and theta.
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {sorted(MODELS)}, got {model!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    system = MODELS[model]
    x0 = check_states(state0, system, name="state0")
    times = _output_times(float(duration), float(dt))
    constants = (params or DEFAULT_PARAMS).constants
    batch = None if x0.ndim == 1 else x0.shape[0]
    if callable(torque):
        policy = torque

        def torque_at(time: float, x: np.ndarray) -> np.ndarray:
            return check_torques(policy(time, x), batch)
    else:
        constant = check_torques(torque, batch)

        def torque_at(_time: float, _x: np.ndarray) -> np.ndarray:
            return constant

    if method == "dop853":
        return times, _simulate_adaptive(system, x0, times, torque_at, constants, rtol, atol)
    if x0.ndim == 1:
        return times, _simulate_scalar(system, scalar_step(method, system), x0, times, torque_at, constants)
    return times, _simulate_batched(system, STEPS[method][1], x0, times, torque_at, constants)


def _simulate_scalar(system: Model, step, x0, times, torque, constants) -> np.ndarray:
    states = np.empty((len(times), system.size))
    states[0] = x0
    x = x0.tolist()
    for i in range(1, len(times)):
        u = torque(times[i - 1], states[i - 1])
        args = (float(u[0, 0]), float(u[1, 0]), *constants)
        try:
            x = step(x, times[i] - times[i - 1], *args)
        except (OverflowError, ZeroDivisionError):
            raise _domain_error(times[i], math.nan) from None
        theta = x[system.lean_index]
        if not (abs(theta) < LEAN_LIMIT and all(map(math.isfinite, x))):
            raise _domain_error(times[i], theta)
        states[i] = x
    return states


def _simulate_batched(system: Model, step, x0, times, torque, constants) -> np.ndarray:
    states = np.empty((len(times), *x0.shape))
    states[0] = x0
    x = padded_rows(*x0.T.shape)
    x[:] = x0.T
    work = workspace(x.shape)
    with np.errstate(all="ignore"):
        for i in range(1, len(times)):
            u = torque(times[i - 1], states[i - 1])
            step(system.batched, x, times[i] - times[i - 1], (u[0], u[1], *constants), work)
            theta = x[system.lean_index]
            if not (np.all(np.abs(theta) < LEAN_LIMIT) and np.all(np.isfinite(x))):
                raise _domain_error(times[i], theta)
            states[i] = x.T
    return states


def _simulate_adaptive(system: Model, x0, times, torque, constants, rtol, atol) -> np.ndarray:
    from scipy.integrate import solve_ivp

    shape = x0.reshape(-1, system.size).T.shape

    def rhs(time, flat):
        x = flat.reshape(shape)
        u = torque(time, x.T.reshape(x0.shape))
        return system.batched(x, x, 0.0, u[0], u[1], *constants, np.empty(shape)).ravel()

    def leaves_domain(_time, flat):
        return LEAN_LIMIT - np.max(np.abs(flat.reshape(shape)[system.lean_index]))

    leaves_domain.terminal = True
    with np.errstate(all="ignore"):
        solution = solve_ivp(
            rhs,
            (times[0], times[-1]),
            x0.reshape(-1, system.size).T.ravel(),
            method="DOP853",
            t_eval=times,
            events=leaves_domain,
            rtol=rtol,
            atol=atol,
        )
    if solution.status == 1:
        time = float(solution.t_events[0][0])
        raise _domain_error(time, solution.y_events[0][0].reshape(shape)[system.lean_index])
    if solution.status != 0 or not np.all(np.isfinite(solution.y)):
        raise _domain_error(float(solution.t[-1]), math.nan)
    return solution.y.reshape(*shape, -1).transpose(2, 1, 0).reshape(len(times), *x0.shape)
