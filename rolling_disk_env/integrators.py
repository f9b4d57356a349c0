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

Contact models (:data:`CONTACTS`): ``"rolling"``, the paper's, is the default and the only one of the lean model;
``"sliding"`` (the paper's frozen lake with kinetic Coulomb friction, :func:`rolling_disk_env.sliding_derivative`)
and ``"coulomb"`` (their hybrid, by Coulomb's law: it rolls while the friction the contact needs is within mu, slides
when it is not, and sticks again where the slip stops and friction can hold it) integrate 10-states, each disk
through its own switching events, with the methods of :data:`CONTACT_METHODS` (see :func:`simulate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rolling_disk_env.constants import CONTACTS, ENGINE_METHODS, EVENT_TIME_TOLERANCE, LEAN_LIMIT, STOP_SLIP, ZERO_SLIP
from rolling_disk_env.dynamics import (
    FULL_MODEL,
    LEAN_MODEL,
    MODELS,
    ROLLING_INDICES,
    SLIDING_MODEL,
    DiskParams,
    Model,
    OutOfDomainError,
    check_friction_coefficient,
    check_states,
    check_torques,
    disk_rows,
    is_number,
)

METHODS = (*ENGINE_METHODS, "dop853")
"""The ``method`` names :func:`simulate` takes: the engine's, then scipy's ``"dop853"`` (the accuracy reference)."""
EVALUATIONS_PER_STEP = {"euler": 1, "symplectic_euler": 2, "rk4": 4}
"""Derivative evaluations per step of the fixed-step methods (the cost unit of the benchmarks)."""
CONTACT_METHODS = ("rk4", "dopri5", "dop853")
"""The methods of the ``"sliding"`` and ``"coulomb"`` contacts. ``"rk4"`` takes fixed steps of dt and locates a
switching event by root-finding on the length of the step that crosses it. ``"dopri5"`` and ``"dop853"`` are scipy's
RK45 (the Dormand-Prince 5(4) pair of the engine's dopri5, with scipy's step control) and DOP853 under ``rtol`` and
``atol``, events located on their dense output. Euler's methods are refused: their first-order error would swamp the
events."""
MAX_SWITCHES = 10_000
"""Switching events one disk may take in a ``"coulomb"`` simulation before it raises (stick-slip chattering)."""
MAX_CONTACT_STEPS = 1_000_000
"""Steps one disk may take in a ``"sliding"`` or ``"coulomb"`` simulation before it raises."""


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
    contact: str = "rolling",
) -> tuple[np.ndarray, np.ndarray]:
    """Integrates the disk from ``state0`` for ``duration`` seconds.

    Args:
        state0: initial state, shape (size,) for one disk or (N, size) for N disks at once; size 8 for the full
            model, 4 for the lean model ``(theta, dphi, dtheta, dpsi)``. Under ``"sliding"`` and ``"coulomb"``,
            size 10 (:data:`rolling_disk_env.SLIDING_STATE_NAMES`), or 8: a rolling state, its centre's velocity
            from the rolling constraint.
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
        friction_coefficient: the contact's friction coefficient mu. Under ``"rolling"``, None (the default) or a
            number > 0: the simulation stops with :class:`RollingContactError` at the first output time where the
            contact needs more (``required_friction > mu``). Under ``"sliding"``, a number >= 0, None meaning 0 (the
            frozen lake). Under ``"coulomb"``, a number >= 0, required.
        contact: one of :data:`CONTACTS`. ``"sliding"`` and ``"coulomb"`` take the ``model="full"``, the methods of
            :data:`CONTACT_METHODS`, and return 10-states; see :func:`simulate_contact`, which also returns the
            switching events. Every contact stops where the normal force vanishes (lift-off).

    Returns:
        ``(times, states)``: times of shape (T,) from 0 to ``duration``, states of shape (T, size) or (T, N, size).

    Raises:
        ValueError: a bad argument (shape, finiteness, unknown method, model or contact).
        OutOfDomainError: the lean reaches ``LEAN_LIMIT``, the state stops being finite or ``"dopri5"`` gives up;
            names the time and theta.
        RollingContactError: (an ``OutOfDomainError``) the disk slipped (under ``"rolling"``) or lifted off; names
            the time, the required friction and the normal force.
    """
    if contact not in CONTACTS:
        raise ValueError(f"contact must be one of {CONTACTS}, got {contact!r}")
    if contact != "rolling":
        trajectory = simulate_contact(
            state0, duration, dt, method, torque, params, model, rtol, atol, friction_coefficient, contact
        )
        return trajectory.times, trajectory.states
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


class SwitchEvent(NamedTuple):
    """A switching event of a disk under the ``"coulomb"`` (or ``"sliding"``) contact.

    Attributes:
        time: s.
        kind: ``"slip"``, the contact needs more friction than mu and the disk starts sliding (at the start too, for
            a rolling start that needs more); ``"stick"``, the slip stopped where friction can hold it and the disk
            rolls again; ``"reslip"``, the slip stopped where friction cannot hold it and the disk slides on, in a
            new direction.
        state: the 10-state there (with zero slip after a ``"stick"`` or ``"reslip"``: after the contact impulse).
        slip: at a stop, the slip speed where the slide was found to end, just before the contact impulse zeroed it
            (m/s; 0 at a slip).
        energy_change: the energy the stop's contact impulse changed (J; never positive, 0 at a slip).
    """

    time: float
    kind: str
    state: np.ndarray
    slip: float = 0.0
    energy_change: float = 0.0


class ContactTrajectory(NamedTuple):
    """What :func:`simulate_contact` returns.

    Attributes:
        times: shape (T,), s.
        states: 10-states, shape (T, 10) or (T, N, 10).
        events: the :class:`SwitchEvent` of one disk in time order, or a tuple of them per disk for a batch.
    """

    times: np.ndarray
    states: np.ndarray
    events: tuple


def simulate_contact(
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
    contact: str = "coulomb",
) -> ContactTrajectory:
    """:func:`simulate` under the ``"sliding"`` or the ``"coulomb"`` contact, with the switching events.

    ``"sliding"``: the sliding model throughout, kinetic friction ``-mu N v / |v|`` at the contact. Its law gives no
    force direction at zero slip, so a disk whose slip is zero starts sliding with the friction the rolling contact
    needs there, at its limit ``mu N`` (the direction in which slip starts), and the simulation raises
    :class:`OutOfDomainError` where the slip is zero and friction could hold it: that disk would roll, which the
    ``"coulomb"`` contact models. With mu = 0 (the frozen lake) the contact force is zero throughout.

    ``"coulomb"``: Coulomb's set-valued law (a contact force within ``mu N`` while the slip is zero, ``-mu N v / |v|``
    otherwise) as Le Saux, Leine and Glocker (2005, *Dynamics of a rolling disk in the presence of dry friction*,
    J. Nonlinear Sci. 15) state it for this disk. They integrate it with a time-stepping scheme; here it is
    event-driven, one mode at a time (on the slip's direction at its onset see also Antali and Stepan, 2019,
    *Nonsmooth analysis of three-dimensional slipping and rolling in the presence of dry friction*, Nonlinear Dyn.
    97):

    * the disk *rolls* (the rolling model, the centre's velocity from the constraint) while the friction it needs is
      within mu, ``|lambda| <= mu N``;
    * it *slips* where ``|lambda|`` reaches ``mu N`` (an event located on ``mu N - |lambda| = 0``), starting with
      zero slip and the friction force ``mu N lambda / |lambda|``, along the force the contact needed (at that
      instant the sliding and the rolling accelerations agree), then slides with kinetic friction;
    * its slide ends where the slip speed reaches zero: ``"rk4"`` closes in on the stop with steps of at most half
      the time the slip's rate of slowing leaves, ``"dopri5"`` and ``"dop853"`` locate ``v . v0 = 0`` on their dense
      output (``v0`` the slip at the start of the step, again from there while the slip left is above the tolerance),
      until the slip speed is below ``rolling_disk_env.constants.STOP_SLIP sqrt(g r)``. There the contact impulse
      that zeroes the slip puts the disk on the rolling constraint: it changes the centre's velocity and the angular
      rates together and can only take energy away (half the impulse times the slip, some 1e-19 J after a stop
      located so). Then the disk *sticks* and rolls again if ``|lambda| <= mu N``, or slides on (``"reslip"``),
      starting as at a slip.

    The switching (the mode at zero slip, the onset's friction, the impulse) is the compiled engine's
    (:func:`rolling_disk_env.engine.contact_phase`, ``sliding.stick``); ``"rk4"`` runs the engine's own steps
    (:func:`rolling_disk_env.engine.contact_run`), those of the env's ``contact="coulomb"``.

    Torques: ``"rk4"`` samples a callable torque at the start of each output interval and holds it over it;
    ``"dopri5"`` and ``"dop853"`` call it at every evaluation; it receives the 10-state. A batch takes constant
    torques only, each disk running through its own events.

    Args:
        state0: (10,) or (N, 10), :data:`rolling_disk_env.SLIDING_STATE_NAMES`; or (8,) or (N, 8), rolling states,
            their centre's velocity from the rolling constraint.
        duration, dt, torque, params, rtol, atol: as for :func:`simulate`.
        method: one of :data:`CONTACT_METHODS`.
        model: ``"full"``, the only model with a centre that can slide.
        friction_coefficient: mu >= 0; under ``"sliding"``, None means 0.
        contact: ``"sliding"`` or ``"coulomb"``.

    Returns:
        A :class:`ContactTrajectory`.

    Raises:
        ValueError: a bad argument.
        OutOfDomainError: the lean reaches ``LEAN_LIMIT``, the state stops being finite, scipy's integrator fails,
            more than :data:`MAX_CONTACT_STEPS` steps or :data:`MAX_SWITCHES` events, or a ``"sliding"`` disk at zero
            slip that friction could hold.
        RollingContactError: the normal force vanished (``reason = "lifted_off"``).
    """
    if contact not in ("sliding", "coulomb"):
        raise ValueError(f"contact must be 'sliding' or 'coulomb' here, got {contact!r}")
    if model != "full":
        raise ValueError(
            f"contact={contact!r} takes model='full' (the lean model has no centre to slide), got {model!r}"
        )
    if method not in CONTACT_METHODS:
        raise ValueError(f"method must be one of {CONTACT_METHODS} under contact={contact!r}, got {method!r}")
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (is_number(value) and 0 < value < 1):
            raise ValueError(f"{name} must be a number in (0, 1), got {value!r}")
    if friction_coefficient is None and contact == "coulomb":
        raise ValueError("contact='coulomb' needs a friction_coefficient (a finite number >= 0)")
    mu = 0.0 if friction_coefficient is None else check_friction_coefficient(friction_coefficient)
    x0 = _sliding_start(state0, params)
    times = _output_times(duration, dt)
    batch = None if x0.ndim == 1 else x0.shape[0]
    if callable(torque) and batch is not None:
        raise ValueError(
            f"a callable torque needs one disk under contact={contact!r} (each disk switches at its own events), "
            f"got a batch of {batch}: simulate them one by one"
        )
    rows = x0.reshape(-1, SLIDING_MODEL.size)
    torques = None if callable(torque) else check_torques(torque, batch)
    disks = disk_rows(params, rows.shape[0])
    states = np.empty((len(times), *rows.shape))
    events = []
    for i, row in enumerate(rows):
        run = _ContactRun(contact, mu, torque if torques is None else torques[i], disks[i], times)
        if method == "rk4":
            states[:, i], disk_events = run.run_rk4(row)
        else:
            states[:, i], disk_events = run.run_adaptive(row, method, rtol, atol)
        events.append(disk_events)
    return ContactTrajectory(
        times, states.reshape(len(times), *x0.shape), events[0] if batch is None else tuple(events)
    )


def _sliding_start(state0, params: DiskParams | None) -> np.ndarray:
    """``state0`` as checked 10-states: as given, or rolling 8-states with the centre's velocity of the constraint."""
    from rolling_disk_env.dynamics import sliding_state

    shape = np.shape(state0)
    if len(shape) not in (1, 2) or shape[-1] not in (8, 10):
        raise ValueError(f"state0 must have shape (8,), (10,), (N, 8) or (N, 10), got {shape}")
    if shape[-1] == 8:
        return sliding_state(check_states(state0, FULL_MODEL, "state0"), params)
    return check_states(state0, SLIDING_MODEL, "state0")


@dataclass
class _Phase:
    """What a disk integrates between two switching events: the rolling model on 8-states, or the sliding model on
    10-states with the friction at zero slip (``onset``, per unit normal force) and the slip direction at the start
    of the current step (``reference``, zeros for none): the engine's ``law``."""

    rolling: bool
    onset: np.ndarray
    reference: np.ndarray


class _ContactRun:
    """One disk through a ``"sliding"`` or ``"coulomb"`` simulation: its phases, switching events and outputs."""

    def __init__(self, contact: str, mu: float, torque, disk: np.ndarray, times: np.ndarray):
        self.contact, self.mu, self.times = contact, mu, times
        self.coulomb = contact == "coulomb"
        self.policy = torque if callable(torque) else None
        self.held = np.zeros(2) if self.policy else np.asarray(torque, dtype=np.float64)
        self.disk = np.ascontiguousarray(disk)
        self.constants = tuple(float(value) for value in disk)  # (m, g, r), as the engine's scalar kernels take them
        self.zero_slip = ZERO_SLIP * math.sqrt(disk[1] * disk[2])
        self.stop_slip = STOP_SLIP * math.sqrt(disk[1] * disk[2])
        self.out = np.empty((len(times), SLIDING_MODEL.size))
        self.events: list[SwitchEvent] = []
        self.steps = 0
        self.per_evaluation = False
        self._rows = (np.empty((1, 8)), np.empty((1, 2)), self.disk.reshape(1, 3), np.empty((1, 8)), np.empty((1, 5)))

    def sample(self, t: float, x: np.ndarray) -> np.ndarray:
        """The torque at ``t`` in the 10-state ``x`` (N m)."""
        return self.held if self.policy is None else check_torques(self.policy(t, x.copy()), None)[0]

    def fail(self, code: int, time: float, x: np.ndarray) -> OutOfDomainError:
        """The error of an engine code that stopped the disk at ``time`` in ``x``."""
        from rolling_disk_env import engine

        if code == engine.LIFTED_OFF:
            normal = engine.hybrid_contact(tuple(x), tuple(self.held), self.mu, self.coulomb, self.constants)[3]
            return _lift_off(time, float(normal))
        if code == engine.SUBSTEP_LIMIT:
            return OutOfDomainError(
                f"the contact switched more than {MAX_SWITCHES} times, or took more than "
                f"{engine.MAX_PERIOD_SEGMENTS} steps in an interval, by t = {time:.6g} s (stick-slip chattering)",
                time=time,
            )
        if not (np.all(np.isfinite(x)) and abs(x[3]) < LEAN_LIMIT):
            return _domain_error(time, x[3] if math.isfinite(x[3]) else math.nan)
        need = engine.contact(tuple(x[list(ROLLING_INDICES)]), *self.held, *self.constants)[4]
        return OutOfDomainError(
            f"at t = {time:.6g} s the slip is zero and friction holds the disk (it needs |lambda| / N = "
            f"{need:.6g} <= friction_coefficient = {self.mu}): the kinetic law of contact='sliding' has no force "
            "there; contact='coulomb' rolls on",
            time=time,
        )

    def record(self, rows: np.ndarray) -> None:
        """Takes the engine's event rows (``engine.EVENT_SIZE`` columns)."""
        from rolling_disk_env import engine

        for row in rows:
            kind = ("", "slip", "stick", "reslip")[int(row[1])]
            self.events.append(SwitchEvent(float(row[0]), kind, row[4:].copy(), float(row[2]), float(row[3])))
        if len(self.events) > MAX_SWITCHES:
            raise self.fail(engine.SUBSTEP_LIMIT, self.events[-1].time, self.events[-1].state)

    def run_rk4(self, x0: np.ndarray) -> tuple[np.ndarray, tuple[SwitchEvent, ...]]:
        """The engine's RK4 steps (:func:`rolling_disk_env.engine.contact_run`), one per output interval, a callable
        torque sampled at the start of each."""
        from rolling_disk_env import engine

        events = np.empty((MAX_SWITCHES, engine.EVENT_SIZE))
        rolled = True
        spans = [(0, len(self.times))] if self.policy is None else [(k, k + 2) for k in range(len(self.times) - 1)]
        x = x0
        for first, stop in spans:
            self.held = self.sample(self.times[first], x)
            torques = np.tile(self.held, (stop - first - 1, 1))
            count, code, time, switches, rolled = engine.contact_run(
                tuple(x.tolist()), self.times[first:stop], torques, self.mu, self.coulomb, self.constants, rolled,
                self.out[first:stop], events,
            )  # fmt: skip
            self.record(events[: min(switches, len(events))])
            if code != engine.RUNNING:
                raise self.fail(code, time, self.out[first + count])  # the state where it stopped
            x = self.out[stop - 1]
        return self.out, tuple(self.events)

    # scipy's methods: the sliding and the rolling models, one disk.
    def _rolling(self, kernel, y: np.ndarray, u: np.ndarray, out: np.ndarray) -> np.ndarray:
        rows, torques, disks = self._rows[0], self._rows[1], self._rows[2]
        rows[0], torques[0] = y, u
        kernel(rows, torques, disks, out)
        return out[0]

    def to_sliding(self, y: np.ndarray) -> np.ndarray:
        """The 10-state of a rolling 8-state: the centre's velocity from the constraint."""
        from rolling_disk_env import engine

        return np.array(engine.rolling_start(tuple(y), *self.constants))

    def torque(self, t: float, y: np.ndarray) -> np.ndarray:
        if not self.per_evaluation:
            return self.held
        return self.sample(t, y if y.size == SLIDING_MODEL.size else self.to_sliding(y))

    def rolling_rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        from rolling_disk_env import engine

        return self._rolling(engine.derivatives, y, self.torque(t, y), self._rows[3]).copy()

    def rolling_contact(self, t: float, y: np.ndarray) -> tuple[float, np.ndarray]:
        """``(N, lambda)`` of a rolling 8-state (N)."""
        from rolling_disk_env import engine

        values = self._rolling(engine.diagnostics, y, self.torque(t, y), self._rows[4])
        return float(values[3]), values[1:3].copy()

    def sliding_rhs(self, phase: _Phase, t: float, y: np.ndarray) -> np.ndarray:
        from rolling_disk_env import engine

        out = np.empty(SLIDING_MODEL.size)
        u = self.torque(t, y)
        engine.hybrid_derivative(y, u, self.mu, phase.onset, phase.reference, self.zero_slip, self.disk, out)
        return out

    def sliding_contact(self, phase: _Phase, t: float, y: np.ndarray) -> tuple[float, np.ndarray]:
        """``(N, v)`` of a sliding 10-state: normal force (N) and slip velocity (m/s)."""
        from rolling_disk_env import engine

        values = engine.hybrid_diagnostics(
            y, self.torque(t, y), self.mu, phase.onset, phase.reference, self.zero_slip, self.disk
        )
        return values[1], np.array(values[4:6])

    def event_function(self, phase: _Phase, t: float, y: np.ndarray, check: bool = False) -> float | None:
        """The phase's switching function, positive until its event (None: no event possible in this step):
        ``mu N - |lambda|`` when rolling, ``v . reference`` when sliding. With ``check``, raises where the state
        has left the domain or the normal force vanished."""
        if check:
            self.steps += 1
            theta = y[3]
            if not (np.all(np.isfinite(y)) and abs(theta) < LEAN_LIMIT):
                raise _domain_error(t, theta if math.isfinite(theta) else math.nan)
            if self.steps > MAX_CONTACT_STEPS:
                raise OutOfDomainError(f"{MAX_CONTACT_STEPS} steps did not reach t = {self.times[-1]:.6g} s", time=t)
        if phase.rolling:
            normal, force = self.rolling_contact(t, y)
            value = self.mu * normal - math.hypot(*force)
        else:
            normal, slip = self.sliding_contact(phase, t, y)
            value = float(slip @ phase.reference) if phase.reference.any() else None
        if check and not normal > 0:
            raise _lift_off(t, normal)
        return value

    def phase_at(self, t: float, x: np.ndarray) -> _Phase:
        """The engine's mode of the 10-state ``x`` (:func:`rolling_disk_env.engine.contact_phase`)."""
        from rolling_disk_env import engine

        u = tuple(self.torque(t, x))
        code, rolling, law = engine.contact_phase(tuple(x), u, self.mu, self.coulomb, self.constants)
        if code != engine.RUNNING:
            raise self.fail(code, t, x)
        return _Phase(rolling, np.array(law[1]), np.array(law[2]))

    def run_adaptive(self, x0: np.ndarray, method: str, rtol: float, atol: float):
        """scipy's RK45 (``"dopri5"``) or DOP853 between the events, outputs from its dense output, a callable torque
        called at every evaluation."""

        self.method, self.rtol, self.atol = method, rtol, atol
        self.per_evaluation = self.policy is not None
        t, k = self.times[0], 1
        self.out[0] = x0
        self.held = self.sample(t, x0)
        phase = self.phase_at(t, x0)
        _, slip = self.sliding_contact(phase, t, x0)
        if not phase.rolling and math.hypot(*slip) <= self.zero_slip and (self.coulomb or self.mu > 0):
            self.events.append(SwitchEvent(t, "slip", x0.copy()))  # a rolling start that needs more than mu
        y = x0[list(ROLLING_INDICES)] if phase.rolling else x0.copy()
        while t is not None:
            if not phase.rolling and self.mu > 0 and not phase.reference.any():  # a slide from zero slip
                t, phase, y, k = self.near_zero_slip(phase, t, y, k)
                continue
            t_event, y_event, k = self.advance_adaptive(phase, t, y, k)
            if t_event is None:
                break
            t = t_event
            if phase.rolling:  # the needed friction reached mu N: slip starts along the needed force
                _, force = self.rolling_contact(t, y_event)
                onset = self.mu * force / math.hypot(*force)
                phase, y = _Phase(False, onset, np.zeros(2)), self.to_sliding(y_event)
                self.events.append(SwitchEvent(t, "slip", y.copy()))
            else:  # near zero slip, or the slip turned back: its stop is near
                t, phase, y, k = self.near_zero_slip(phase, t, y_event, k)
            if len(self.events) > MAX_SWITCHES:
                raise OutOfDomainError(
                    f"the contact switched more than {MAX_SWITCHES} times by t = {t:.6g} s (stick-slip chattering)",
                    time=t,
                )
        return self.out, tuple(self.events)

    def near(self, x: np.ndarray) -> bool:
        """Whether a sliding 10-state is near zero slip, where the engine's steps slave the slip's direction
        (:data:`rolling_disk_env.engine.EXPLICIT_FROM`, with N = m g)."""
        from rolling_disk_env import engine

        speed = math.hypot(*self.sliding_contact(_Phase(False, np.zeros(2), np.zeros(2)), 0.0, x)[1])
        return engine.TURN * speed < engine.EXPLICIT_FROM * 5 * self.mu * self.disk[1]

    def near_zero_slip(self, phase: _Phase, t: float, y: np.ndarray, k: int):
        """A slide from ``(t, y)`` near zero slip, at its start or near its stop, by the engine's steps
        (:func:`rolling_disk_env.engine.contact_segment`, the one implementation of a slide's start, its stop and its
        impulse: near zero slip the slip's direction turns faster than scipy's steps follow), which write the outputs
        they pass. Returns ``(t, phase, y, k)`` after an event, or once the slip is no longer near zero
        (:meth:`near`), or ``(None, None, None, k)`` at the end."""
        from rolling_disk_env import engine

        law = (self.mu, tuple(phase.onset), tuple(phase.reference), self.zero_slip)
        x, rolling = tuple(y.tolist()), False
        while k < len(self.times):
            state = np.array(x)
            if not self.near(state) and np.any(law[2]):  # on with scipy's steps, from the slip's direction
                return t, _Phase(False, np.array(law[1]), np.array(law[2])), state, k
            u = tuple(self.torque(t, state))
            left = self.times[k] - t
            x, rolling, law, used, code, kind, slip, change = engine.contact_segment(
                x, rolling, law, left, u, self.mu, self.coulomb, self.constants
            )
            state, phase = np.array(x), _Phase(rolling, np.array(law[1]), np.array(law[2]))
            if used < left:
                t += used
            else:
                t, self.out[k], k = self.times[k], state, k + 1
            if not (np.all(np.isfinite(state)) and abs(state[3]) < LEAN_LIMIT):
                raise _domain_error(t, state[3] if math.isfinite(state[3]) else math.nan)
            if kind != engine.NO_EVENT:
                if code != engine.RUNNING:
                    raise self.fail(code, t, state)
                self.events.append(SwitchEvent(t, ("", "slip", "stick", "reslip")[kind], state.copy(), slip, change))
                return t, phase, (state[list(ROLLING_INDICES)] if rolling else state), k
            self.steps += 1
            if self.steps > MAX_CONTACT_STEPS:
                raise OutOfDomainError(f"{MAX_CONTACT_STEPS} steps did not reach t = {self.times[-1]:.6g} s", time=t)
        return None, None, None, k

    def full(self, phase: _Phase, y: np.ndarray) -> np.ndarray:
        return self.to_sliding(y) if phase.rolling else y

    def set_reference(self, phase: _Phase, t: float, y: np.ndarray) -> None:
        """Starts a sliding step at ``y``: the direction of its slip, where there is one, and mu > 0."""
        if phase.rolling:
            return
        _, slip = self.sliding_contact(phase, t, y)
        speed = math.hypot(*slip)
        phase.reference = slip / speed if self.mu > 0 and speed > self.zero_slip else np.zeros(2)

    def advance_adaptive(self, phase: _Phase, t: float, y: np.ndarray, k: int):
        """scipy's RK45 or DOP853 from ``(t, y)``, outputs from its dense output: ``(t, y, k)`` at the phase's first
        event (located on the dense output of the step that crosses it; k: the next output to write), or after a
        sliding step that ends near zero slip, where friction turns the slip's direction in less than its length (then
        :meth:`near_zero_slip` goes on), or ``(None, None, k)`` at the end."""
        from scipy.integrate import DOP853, RK45

        def rhs(time, state):
            return self.rolling_rhs(time, state) if phase.rolling else self.sliding_rhs(phase, time, state)

        stepper = (DOP853 if self.method == "dop853" else RK45)(
            rhs, t, y, self.times[-1], rtol=self.rtol, atol=self.atol
        )
        self.set_reference(phase, t, y)
        while stepper.status == "running":
            before = self.event_function(phase, t, y)
            with np.errstate(all="ignore"):
                message = stepper.step()
            if stepper.status == "failed":
                raise OutOfDomainError(f"{self.method} failed at t = {stepper.t:.6g} s: {message}", time=stepper.t)
            new = stepper.y.copy()
            after = self.event_function(phase, stepper.t, new, check=True)
            dense = stepper.dense_output()
            if before is not None and before > 0 >= after:
                time = _root(lambda s, dense=dense: self.event_function(phase, s, dense(s)), t, stepper.t)
                return time, dense(time), self.fill(phase, dense, time, k)
            k = self.fill(phase, dense, stepper.t, k)
            t, y = stepper.t, new
            if not phase.rolling and self.mu > 0 and self.near(y):
                return t, y, k
            self.set_reference(phase, t, y)
        return None, None, k

    def fill(self, phase: _Phase, dense, end: float, k: int) -> int:
        """Writes the outputs up to ``end`` from a step's dense output; returns the next output to write."""
        stop = int(np.searchsorted(self.times, end, side="right"))
        if stop > k:
            for j, y in zip(range(k, stop), dense(self.times[k:stop]).T):
                self.out[j] = self.full(phase, y)
        return max(k, stop)


def _root(function, low: float, high: float) -> float:
    """Where ``function`` (positive at ``low``, not at ``high``) vanishes, within :data:`EVENT_TIME_TOLERANCE`."""
    from scipy.optimize import brentq

    if not function(high) < 0:
        return high
    return brentq(function, low, high, xtol=EVENT_TIME_TOLERANCE)


def _lift_off(time: float, normal: float) -> RollingContactError:
    return RollingContactError(
        f"at t = {time:.6g} s the normal force vanished: the disk lifted off the plane (N = {normal:.6g} N)",
        time=time,
        reason="lifted_off",
        required_friction=math.inf,
        normal_force=normal,
    )
