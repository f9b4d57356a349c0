"""The compiled engine: what a batch of disks runs in a control period, and the model API's loops.

Everything here is compiled by numba (:mod:`rolling_disk_env.jit`) from plain Python on floats and arrays:

* the model's kernels, generated from the SymPy derivation (``_generated/kernels.py``): derivatives, one step of each
  integrator with its stages written out, energy and contact forces;
* the pieces every task's step shares, below: the action's torques, the error-controlled integration of a control
  period (``"dopri5"``), the contact checks, the domain check, the success rule;
* the fused step of each task (``_generated/<task>.py``, written by :mod:`rolling_disk_env.codegen` from a template):
  a share of a batch of disks through a control period, in loops over the disks that the compiler vectorizes
  (integration; contact forces and checks, the task's termination, reward terms, success and observation), then the
  reset of the share's disks whose episodes start anew (Gymnasium's next-step autoreset), called for a range of
  shares on the calling thread, or for each share at once on numba's threads (:func:`step_shares`);
* the batch loops of the model API (:mod:`rolling_disk_env.dynamics`, :func:`rolling_disk_env.simulate`).

The single env and the vector env call the same generated functions, so they give the same transitions to the last
bit. A batch keeps its disks in a *lanes* array (:data:`LANES` rows, one column per disk, updated in place) and
returns its outputs in an info block (a column per disk, rows from :data:`ENERGY` to the reward terms at
:data:`TERMS`); the model API takes rows of states, (N, 8) float64. How a batch is split into shares and when it
uses threads: :mod:`rolling_disk_env.envs.batch`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numba.core import types
from numba.experimental import structref

from rolling_disk_env._generated import kernels, sliding
from rolling_disk_env.constants import CONTACTS, ENGINE_METHODS, EVENT_TIME_TOLERANCE, LEAN_LIMIT, STOP_SLIP, ZERO_SLIP
from rolling_disk_env.jit import inline_kernel, kernel, parallel_kernel, prange
from rolling_disk_env.trig import sincos

METHODS = ENGINE_METHODS
"""The engine's integrators, by code (their index): fixed steps, then the error-controlled Dormand-Prince 5(4)."""
ADAPTIVE = METHODS.index("dopri5")
MAX_ADAPTIVE_SUBSTEPS = 10_000
"""Steps (accepted or rejected) that ``"dopri5"`` may take in one control period or output interval; past it the
episode ends with ``"substep_limit"`` (``simulate`` raises) instead of looping on."""

RUNNING, FALLEN, OUT_OF_DOMAIN, SLIPPED, LIFTED_OFF, SUBSTEP_LIMIT, REACHED, OFF_COURSE = range(8)
"""Termination codes of a disk after a step: the episode goes on; the task's own (a task's ``termination`` returns
RUNNING, FALLEN, REACHED or OFF_COURSE, the last where the disk strayed past the task's tracking bound); the
integrator leaving the model's domain, the contact needing more friction than ``friction_coefficient``, the normal
force vanishing, ``"dopri5"`` giving up."""

STATE = 0
TAU_SPIN, TAU_STEER, EFFORT, MASS, GRAVITY, RADIUS, MU, STEP_SIZE, TRACKING_SUM = range(8, 17)
PREVIOUS = 17
CENTRE_VELOCITY = 25
TRACKING_WEIGHT = 27
ANGLES = 28
SLIDES = 32
LANES = 33
"""Rows of a batch's *lanes* array (a column per disk, and idle padding columns), which the step reads and writes in
place: the state (8 rows from STATE), the torques (N m) and effort of the action, the disk's m, g, r and friction
coefficient mu (MU: the ``"sliding"`` and ``"coulomb"`` contacts' coefficient, drawn per episode like the others where
``params_ranges`` asks; the ``"rolling"`` contact reads its one ``friction_coefficient`` from ``config``), dopri5's
step size (s), the task's tracking error summed over the episode with exponential weights (TRACKING_SUM,
:func:`track`), the state at the start of the control period (8 rows from PREVIOUS: with substeps, and under the
``"sliding"`` and ``"coulomb"`` contacts), under those contacts the centre's horizontal velocity (dc1, dc2) (2 rows
from CENTRE_VELOCITY), with which the 8 state rows make the 10-state, the sum of those weights (TRACKING_WEIGHT), the
state's ``kernels.angles`` (4 rows from ANGLES: the sines and cosines of theta and psi, which the end of a step and the
reset compute from the state they store and the fixed-step integrators' first stage reads), and under the contacts
1.0 where the disk slides (SLIDES; 0.0 where it rolls). A loop over the disks reads and writes rows, so it can
vectorize."""
DISK_CONSTANTS = 4
"""The disk's constants in the lanes, rows MASS to MU: m, g, r and mu, the order of ``disk_ranges``
(:class:`SetupArrays`) and of the values a reset draws."""

ENERGY, LAMBDA1, LAMBDA2, NORMAL_FORCE, REQUIRED_FRICTION, REWARD = range(8, 14)
"""Rows of an info block (a column per disk, and padding) after the 8 state rows: energy (J), contact force
(N), normal force (N), the friction coefficient the contact needs, the reward; then the reward terms from row TERMS,
then the observation (clipped to its bounds)."""
TERMS = 14
TERMINATED, TRUNCATED, SUCCESS = range(3)
"""Rows of a flags block (booleans, one column per disk)."""

PERIOD, SUBSTEPS, RTOL, ATOL, FRICTION, MAX_STEPS, SUCCESS_BOUND, CONTACT, SUCCESS_DECAY = range(9)
"""Entries of an env's ``config`` array: control period (s), fixed substeps, dopri5's tolerances, the friction
coefficient (inf: ideal rolling; under the ``"sliding"`` and ``"coulomb"`` contacts, mu), episode steps before
truncation (0: none, as in the single env, whose TimeLimit wrapper truncates), the bound of the task's success rule
(the rule itself is written into the task's generated step), the contact model (:data:`ROLLING`, :data:`SLIDING` or
:data:`COULOMB`), and the success rule TRACK's weight of the past at each step, ``exp(-period / time constant)``
(:func:`track`)."""
ROLLING, SLIDING, COULOMB = (float(CONTACTS.index(name)) for name in ("rolling", "sliding", "coulomb"))
"""The contact models' codes, the entry CONTACT of a ``config`` array (their index in
:data:`~rolling_disk_env.constants.CONTACTS`)."""
SLIDING_INFO = ("dc1", "dc2", "v1", "v2", "sliding")
"""Rows of an info block after the observation under the ``"sliding"`` and ``"coulomb"`` contacts: the centre's
horizontal velocity and the slip velocity (m/s), and 1 where the disk slides (0 where it rolls)."""


class BatchArrays(NamedTuple):
    """What a batch of disks carries from one step to the next, updated in place by the step and the reset.

    The generated kernels take the arrays of each bundle as a plain tuple, in this order, and unpack it into these
    names; a batch hands this tuple and its :class:`SetupArrays` to them in a :class:`Bundle`.

    Attributes:
        lanes: (LANES, columns) float64, the rows described at :data:`LANES`.
        goals: (goal size, columns) float64, each episode's targets and task state (the task's ``goal_names``, then
            its ``progress_names``).
        steps: (columns,) int64, steps since each episode started.
    """

    lanes: np.ndarray
    goals: np.ndarray
    steps: np.ndarray


class SetupArrays(NamedTuple):
    """An env's settings, as the kernels read them (never written).

    Attributes:
        config: the entries from :data:`PERIOD` on (float64).
        actuators: (action size, 2): per action component, the torque it drives (0 spin, 1 steer) and the torque
            of action +1 (N m).
        settings: the task's options (its ``setting_names``).
        weights: the reward terms' weights.
        bounds: the observation's bounds (float32).
        disk_ranges: (DISK_CONSTANTS, 3): per disk constant (m, g, r, mu), its range and whether it is drawn.
        ranges: (drawn values, 2): the ranges of the task's goal and initial state.
    """

    config: np.ndarray
    actuators: np.ndarray
    settings: np.ndarray
    weights: np.ndarray
    bounds: np.ndarray
    disk_ranges: np.ndarray
    ranges: np.ndarray


@structref.register
class BundleType(types.StructRef):
    """numba's type of a :class:`Bundle`: its fields' types (tuples of arrays)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class Bundle(structref.StructRefProxy):
    """A batch's arrays and compiled functions as the engine's callers take them, built once (:func:`bundle`):
    ``batch``, the arrays of :class:`BatchArrays` split into shares, ``setup``, those of :class:`SetupArrays`, and
    ``resets``, those of :class:`ResetArrays` (the batch's own: it writes the disks to reset into their mask), each a
    plain tuple; ``step`` and ``reset``, the configuration's compiled share functions (``_generated/<task>.py``'s
    ``step_<method>_share`` and ``reset_share`` or ``reset_contact_share``) as first-class functions
    (:func:`rolling_disk_env.jit.first_class`).

    A compiled function called from Python unboxes each array it is passed (reads its shape, strides and data
    pointer), about 0.1 us an array: the twelve arrays of a batch and its settings cost a single env's step more than
    its disk's arithmetic. A bundle (a numba structure, passed as one pointer) is unboxed at once: measured with a
    kernel that returns at once, 0.40 to 0.49 us a call with the bundle, the actions, the outputs and no resets,
    against 1.00 to 1.29 us with the twelve arrays in tuples (Intel Xeon). The resets travel in it too, so that a
    step with resets and one without are one compiled function at the cost of one without. So do the share
    functions: a first-class function passed as an argument is unboxed at every call (measured: 3.1 us, AMD EPYC),
    one kept in the bundle costs 0.14 us a call, and the callers (:func:`step_range`, :func:`step_shares`) are then
    the same compiled functions for every task, contact and integrator.
    """


structref.define_constructor(Bundle, BundleType, ["batch", "setup", "resets", "step", "reset"])
structref.define_boxing(BundleType, Bundle)


class InterpretedBundle(NamedTuple):
    """:class:`Bundle` where numba's JIT is disabled (``NUMBA_DISABLE_JIT=1``): the callers read the same fields."""

    batch: tuple
    setup: tuple
    resets: tuple
    step: object
    reset: object


@kernel
def _compiled_bundle(batch, setup, resets, step, reset):
    return Bundle(batch, setup, resets, step, reset)


def bundle(batch: tuple, setup: tuple, resets: tuple, step, reset) -> Bundle | InterpretedBundle:
    """The :class:`Bundle` of a batch's arrays (split into shares), settings and resets, given as plain tuples, and
    its share functions (first-class functions): built by a cached kernel (about 7 us a call; calling ``Bundle`` from
    Python compiles its constructor in every process)."""
    if numba.config.DISABLE_JIT:
        return InterpretedBundle(batch, setup, resets, step, reset)
    return _compiled_bundle(batch, setup, resets, step, reset)


class OutputArrays(NamedTuple):
    """What a step or a reset writes, a column (a row for ``observations``) per disk.

    Attributes:
        observations: (columns, observation size) float32, clipped to the bounds.
        info: (TERMS + terms + observation size, columns) float64: the rows from :data:`ENERGY` on, the reward terms
            from row :data:`TERMS`, then the observation.
        flags: (3, columns) bool: the rows :data:`TERMINATED`, :data:`TRUNCATED`, :data:`SUCCESS`.
        codes: (columns,) int64, the termination codes (:data:`RUNNING` where the episode goes on). An int64 array
            of their own rather than a row of ``info``: the step's loops load and store them as vectors, where a
            float row needs a scalar conversion a disk (AVX2 has none for int64), and the env hands them out as they
            are (measured with ``circle``'s step compiled for AVX2, N = 4096, one thread: 42.4 against 44.2 ns a
            disk, medians of 5 interleaved fresh processes).
    """

    observations: np.ndarray
    info: np.ndarray
    flags: np.ndarray
    codes: np.ndarray


class ResetArrays(NamedTuple):
    """Which disks start a new episode, and what they draw it from (a row or an entry per disk, N in all; disk i of
    share k at ``k * columns + i``).

    Attributes:
        mask: (N,) bool, the disks to reset.
        rngs: (N, 4) uint64, each disk's PCG64 state (:mod:`rolling_disk_env.pcg64`), advanced by the draws; or (0, 4)
            to take the draws from ``uniforms`` as they are.
        uniforms: (N, draws) float64, each disk's uniforms in [0, 1) for its episode (overwritten by the draws).
        given: (N, 8) float64 (or more columns, of which the first 8 are read), initial states that replace the
            drawn ones; rows of NaN: none.
    """

    mask: np.ndarray
    rngs: np.ndarray
    uniforms: np.ndarray
    given: np.ndarray


NEXT_STEP, SAME_STEP, DISABLED = range(3)
"""The autoreset modes (Gymnasium's ``AutoresetMode``) as the device's step kernels take them
(``DeviceControl.mode``)."""


class DeviceControl(NamedTuple):
    """What a device step kernel (``_generated/cuda.py``, a GPU thread a disk of a batch of N shares of one disk) reads
    and writes beside the batch, so that a step needs nothing from the host but its actions: the autoreset is decided
    on the device (:func:`device_step_due`, :func:`device_step_ended`).

    Attributes:
        status: (2,) int64: the first disk whose action is not finite, and under DISABLED the first disk that has
            ended; N where there is none. Written by the device's check before the step (``rolling_disk_env.gpu``):
            where either is below N, the step steps nothing.
        ended: (N,) bool, the disks whose episode ended at their latest step (never set under SAME_STEP, whose
            disks start again at once).
        rewards: (N,) float32, the step's rewards.
        dones: (2, N) bool, the step's flags terminated and truncated, as the step ended (before a same-step reset).
        final: the :class:`OutputArrays` (split into N shares) of the disks' last outputs, where they ended
            (SAME_STEP).
        final_mask: (N,) bool, the disks whose episode the step ended (SAME_STEP).
        final_disk: (DISK_CONSTANTS, N) float64, the disks' constants (m, g, r, mu: lanes rows MASS to MU) where they
            ended (SAME_STEP), for ``final_info``'s drawn values.
        mode: :data:`NEXT_STEP`, :data:`SAME_STEP` or :data:`DISABLED`.
        queue: (N + 1,) int64, under the ``"sliding"`` and ``"coulomb"`` contacts: ``queue[0]`` disks that the step's
            rolling pass left to the hybrid, ``queue[1:]`` those disks (in no set order), for the step's second kernel;
            the count set to 0 by the check before each step.
    """

    status: np.ndarray
    ended: np.ndarray
    rewards: np.ndarray
    dones: np.ndarray
    final: tuple
    final_mask: np.ndarray
    final_disk: np.ndarray
    mode: int
    queue: np.ndarray


@inline_kernel
def device_step_due(k, control, mask) -> bool:
    """Whether disk k of a device batch steps (not where the check found a non-finite action, or under DISABLED an
    ended disk: then no disk steps), and its entry of the resets' ``mask``: under NEXT_STEP a disk whose episode ended
    at its previous step starts a new one in this step, its action ignored; otherwise no disk yet."""
    status, ended, mode = control[0], control[1], control[7]
    if status[0] < ended.shape[0] or status[1] < ended.shape[0]:
        return False
    mask[k] = ended[k] and mode == NEXT_STEP
    return True


@inline_kernel
def device_step_ended(k, out, lanes, control, mask) -> bool:
    """After disk k's step (and its next-step reset): its reward as float32 and its flags terminated and truncated
    into ``control``, and whether its episode ended; under SAME_STEP, where it ended, its outputs kept in
    ``control.final``, its constants (``lanes`` rows MASS to MU) in ``control.final_disk``, and its entry of the
    resets' ``mask`` set: returns True where the disk must start its next episode now (the kernel then resets it)."""
    observations, info, flags, codes = out
    _, ended, rewards, dones, final, final_mask, final_disk, mode, _ = control
    terminated, truncated = flags[TERMINATED, k, 0], flags[TRUNCATED, k, 0]
    rewards[k] = np.float32(info[REWARD, k, 0])
    dones[0, k], dones[1, k] = terminated, truncated
    now = terminated or truncated
    if mode != SAME_STEP:
        ended[k] = now
        return False
    final_mask[k] = now
    if now:
        kept_observations, kept_info, kept_flags, kept_codes = final
        for j in range(observations.shape[2]):
            kept_observations[k, 0, j] = observations[k, 0, j]
        for j in range(info.shape[0]):
            kept_info[j, k, 0] = info[j, k, 0]
        for j in range(flags.shape[0]):
            kept_flags[j, k, 0] = flags[j, k, 0]
        kept_codes[k, 0] = codes[k, 0]
        for j in range(DISK_CONSTANTS):
            final_disk[j, k] = lanes[MASS + j, k, 0]
        mask[k] = True
    return now


@inline_kernel
def action_torques(actions, actuators, lanes, k, disks):
    """Writes the torques (N m) and the effort (the mean squared clipped action) of the ``disks`` disks of share k into
    their lanes, from their normalized actions (rows ``k * n ...`` of ``actions``, n disks a share) clipped to
    [-1, 1]. ``actuators`` has a row per action component: (torque 0 (spin) or 1 (steer), the torque of action +1 in
    N m)."""
    count, first = actions.shape[1], k * lanes.shape[2]
    for i in range(disks):
        lanes[TAU_SPIN, k, i] = lanes[TAU_STEER, k, i] = lanes[EFFORT, k, i] = 0.0
    for j in range(count):
        row, limit = TAU_SPIN + int(actuators[j, 0]), actuators[j, 1]
        for i in range(disks):
            value = min(max(float(actions[first + i, j]), -1.0), 1.0)
            lanes[EFFORT, k, i] += value * value / count
            lanes[row, k, i] = limit * value


@inline_kernel
def remember(lanes, k):
    """Keeps the states of the disks of share k in their rows PREVIOUS (before the substeps of a period)."""
    for j in range(8):  # the loop over disks innermost, where the compiler vectorizes it
        for i in range(lanes.shape[2]):
            lanes[PREVIOUS + j, k, i] = lanes[STATE + j, k, i]


@inline_kernel
def restore(lanes, codes, k):
    """Puts the states kept by :func:`remember` back in the disks of share k whose last substep left the model's
    domain (code OUT_OF_DOMAIN, :func:`in_domain`), so that such a step ends where its period started. The loop of
    the last substep checks the domain against the state before that substep, and so reads no rows PREVIOUS: with one
    substep, the default, they are not read at all."""
    for j in range(8):  # the loop over disks innermost, where the compiler vectorizes it
        for i in range(lanes.shape[2]):
            left = codes[k, i] == OUT_OF_DOMAIN
            lanes[STATE + j, k, i] = lanes[PREVIOUS + j, k, i] if left else lanes[STATE + j, k, i]


@kernel
def in_domain(start, x, code):
    """``(x, code)`` after integrating from the state ``start`` to ``x``: where ``x`` is not finite or has left the
    model's domain, ``start`` and OUT_OF_DOMAIN instead (branch-free, so that a loop over disks vectorizes)."""
    total = x[0] + x[1] + x[2] + x[3] + x[4] + x[5] + x[6] + x[7]
    inside = math.isfinite(total) and abs(x[3]) < LEAN_LIMIT
    kept = (
        x[0] if inside else start[0], x[1] if inside else start[1], x[2] if inside else start[2],
        x[3] if inside else start[3], x[4] if inside else start[4], x[5] if inside else start[5],
        x[6] if inside else start[6], x[7] if inside else start[7],
    )  # fmt: skip
    return kept, (code if inside else OUT_OF_DOMAIN)


@inline_kernel
def contact(x, tau_spin, tau_steer, m, g, r):
    """``(energy, lambda1, lambda2, normal_force, required_friction)``: J, the horizontal and vertical ground
    reactions (N), and the friction coefficient the contact needs, ``|lambda| / N`` (inf when N <= 0)."""
    energy, lambda1, lambda2, normal = kernels.diagnostics(x, tau_spin, tau_steer, m, g, r)
    required = math.sqrt(lambda1 * lambda1 + lambda2 * lambda2) / normal if normal > 0.0 else math.inf
    return energy, lambda1, lambda2, normal, required


@inline_kernel
def centre_velocity(x, trig, m, g, r):
    """``(dc1, dc2)``: the horizontal velocity (m/s) of the centre of a disk rolling in the 8-state ``x``, whose
    angles' sines and cosines are ``trig`` (``kernels.angles(x)``), from the rolling constraint (the model's kinematic
    equations: the compiler drops the rest of the derivative)."""
    slope = kernels.state_derivative_from(x, trig, 0.0, 0.0, m, g, r)
    return slope[0], slope[1]


@inline_kernel
def transpose(info, first, size, observations, k):
    """Copies the observations (``size`` values) of the disks of share k from their columns of ``info`` (rows from
    ``first``) into their rows of ``observations``, a disk at a time. ``size`` is a constant of the caller, so that
    the compiler unrolls the inner loop and stores a disk's values together. (Measured alone on an Intel Xeon, 4096
    disks of 4, 7 and 8 values: 1.8, 2.8 and 3.4 ns a disk with AVX2 code against 2.1, 4.9 and 6.6 a row of ``info``
    at a time; AVX-512 code 1.6, 2.6 and 3.0 against 1.7, 4.9 and 6.7.)"""
    for i in range(observations.shape[1]):
        for j in range(size):
            observations[k, i, j] = info[first + j, k, i]


@kernel
def first_nonfinite(actions) -> int:
    """The first row of ``actions`` (float32, C-contiguous) holding NaN or inf, or -1. First a count of the values
    whose exponent bits are all ones (NaN or inf), in a loop without an exit, which the compiler vectorizes (a
    boolean "or" it did not: 0.55 against 0.19 ns a disk, two actions a disk, AVX2 code); the rows are searched only
    when there are some (the search alone, a scalar loop that returns early, cost about 1.4 ns a disk of
    ``circle``'s step compiled for AVX2, N = 4096, one thread)."""
    bits = actions.reshape(-1).view(np.uint32)
    exponent = np.uint32(0x7F800000)
    nonfinite = 0
    for i in range(bits.size):
        nonfinite += (bits[i] & exponent) == exponent
    if nonfinite:
        for i in range(actions.shape[0]):
            for j in range(actions.shape[1]):
                if not math.isfinite(actions[i, j]):
                    return i
    return -1


@kernel
def step_range(actions, arrays, out, stepping, shares) -> int:
    """Steps the shares ``shares[0]`` to ``shares[1] - 1`` of a batch (``arrays``, its :class:`Bundle`) where
    ``stepping``, each through its share function ``arrays.step``, then starts the new episodes of the resets' mask
    in it (``arrays.reset``, while the share's rows are in cache: their actions are ignored, their outputs are their
    first ones), and returns the first disk of the whole batch with a non-finite action (then nothing is stepped), or
    -1; else only starts the episodes of the resets' mask in those shares and returns -1. One compiled function for
    every task, contact and integrator, in the single env and the vector env, whether the shares run one after the
    other or at once (:func:`step_shares` calls it on one share a thread): it calls the share functions through their
    addresses, so it links none of their code (numba would optimize and emit a called kernel's code again in its
    caller: a configuration's step and reset compiled in about half the time this way, ``docs/performance/history.md``).
    """
    batch, setup, resets = arrays.batch, arrays.setup, arrays.resets
    if not stepping:
        for k in range(shares[0], shares[1]):
            arrays.reset(np.int64(k), resets, batch, setup, out)
        return -1
    bad = first_nonfinite(actions)
    if bad < 0:
        for k in range(shares[0], shares[1]):
            arrays.step(np.int64(k), actions, batch, setup, out)
            arrays.reset(np.int64(k), resets, batch, setup, out)
    return bad


@parallel_kernel
def step_shares(actions, arrays, out, stepping) -> int:
    """:func:`step_range` on each share of the batch at once, a share per numba thread; returns what it returns (each
    call checks every action, so all return the first disk with a non-finite action, or -1). A share function called
    through its address must not raise: numba's C wrapper would take the GIL on a worker thread while the calling
    thread holds it (the generated steps raise nothing)."""
    shares = arrays.batch[0].shape[1]
    bad = np.empty(shares, dtype=np.int64)
    for k in prange(shares):
        first = np.int64(k)
        bad[k] = step_range(actions, arrays, out, stepping, (first, first + 1))
    return bad[0]


@inline_kernel
def contact_status(normal, required, friction) -> int:
    """LIFTED_OFF when the normal force vanishes, SLIPPED when the contact needs more than ``friction``, else 0."""
    return LIFTED_OFF if not normal > 0.0 else (SLIPPED if required > friction else RUNNING)


@kernel
def next_step_size(h, step, error):
    """The step size to try after a dopri5 step of ``step`` seconds (``h`` was proposed; ``step`` may have been cut
    short by the end of the interval) with error norm ``error`` (accepted when <= 1): ``step * 0.9 error^(-1/5)``,
    the factor within [0.2, 5]; a step cut short does not shrink the next one."""
    if error <= 1.0:
        factor = 5.0 if error == 0.0 else min(5.0, max(0.2, 0.9 * error**-0.2))
        return max(h, step * factor) if step < h else step * factor
    return step * 0.2 if not error < 1e30 else step * max(0.2, 0.9 * error**-0.2)


@kernel
def advance_adaptive(x, period, h, tau_spin, tau_steer, m, g, r, rtol, atol):
    """Integrates the full model over ``period`` seconds with dopri5 steps under the tolerances, starting from the
    step size ``h``. Returns ``(x, h, ok)``: the state, the step size to start the next period with, and False
    when :data:`MAX_ADAPTIVE_SUBSTEPS` steps did not reach the end."""
    t = 0.0
    for _ in range(MAX_ADAPTIVE_SUBSTEPS):
        if t >= period:
            break
        step = min(h, period - t)
        new, error = kernels.state_dopri5_step(x, step, tau_spin, tau_steer, m, g, r, rtol, atol)
        h = next_step_size(h, step, error)
        if error <= 1.0:
            t, x = (period if step == period - t else t + step), new
    return x, h, t >= period


@kernel
def lean_advance_adaptive(y, period, h, tau_spin, tau_steer, m, g, r, rtol, atol):
    """:func:`advance_adaptive` for the lean model."""
    t = 0.0
    for _ in range(MAX_ADAPTIVE_SUBSTEPS):
        if t >= period:
            break
        step = min(h, period - t)
        new, error = kernels.lean_dopri5_step(y, step, tau_spin, tau_steer, m, g, r, rtol, atol)
        h = next_step_size(h, step, error)
        if error <= 1.0:
            t, y = (period if step == period - t else t + step), new
    return y, h, t >= period


NEWTON_STEPS = 12
"""Newton steps :func:`steady_circle` allows. From its start its iteration converges monotonically and quadratically:
over 400,000 circles drawn log-uniformly from 0.05 m to 10 km in radius and 1 mm/s to 1 km/s in speed, those of the
model's domain took at most 6 steps to converge to 1e-15, the ``circle`` task's 3 or 4. JAX reads the loop as this
many unrolled copies (:mod:`rolling_disk_env.jax.reading`), which the JAX env evaluates at every step (gymnax computes
a reset with each step for its autoreset)."""


@kernel
def steady_circle(radius, speed, g, r):
    """The steady circle of the centre path of ``radius`` (m) at ``speed`` (m/s), counter-clockwise:
    ``(theta, dphi, dpsi)`` (rad, rad/s), or NaNs where there is none (:func:`rolling_disk_env.dynamics.steady_circle`
    says why)."""
    dpsi = speed / radius
    if not dpsi * dpsi < 4.0 * g / r:
        return math.nan, math.nan, math.nan
    a, b, c = 2.0 * g / (3.0 * r * dpsi), dpsi / 6.0, speed / r
    # The condition a tan(theta) - b sin(theta) = c in t = tan(theta): excess(t) = a t - b t / sqrt(1 + t^2) - c is
    # increasing (a > b while dpsi^2 < 4 g / r) and convex for t >= 0, so Newton's method converges monotonically
    # from any point right of the root, such as (b + c) / a, where excess >= 0. Its steps take a square root, not
    # the three libm calls of a step in theta (the reset of every circle episode solves it).
    t = (b + c) / a
    for _ in range(NEWTON_STEPS):
        secant = math.sqrt(1.0 + t * t)
        step = (a * t - b * t / secant - c) / (a - b / (secant * secant * secant))
        t -= step
        if abs(step) < 1e-15 * (1.0 + t * t):  # theta moved by less than 1e-15 rad
            break
    theta = math.atan(t)
    if not theta < LEAN_LIMIT:
        return math.nan, math.nan, math.nan
    return theta, speed / r + dpsi * (t / math.sqrt(1.0 + t * t)), dpsi


@inline_kernel
def track(total, weight, error, decay, bound):
    """The success rule TRACK for one disk after a step whose tracking error is ``error``: ``(total, weight,
    within)``, the disk's exponentially weighted sum of its errors and sum of weights (rows TRACKING_SUM and
    TRACKING_WEIGHT, zero at the reset) updated, and whether their ratio, the bias-corrected exponentially weighted
    mean of the error over the episode, is within ``bound``.

    ``decay`` is ``exp(-period / tau)`` (the entry SUCCESS_DECAY of ``config``): the error of a step ``n`` steps ago
    weighs ``decay^n`` against this step's, so the mean forgets the past with the time constant tau (s). Two numbers a
    disk, whatever the episode's length (which the single env does not know: Gymnasium's TimeLimit truncates it), and
    no branch: the loop over the disks vectorizes."""
    total = decay * total + error
    weight = decay * weight + 1.0
    return total, weight, total <= bound * weight


# The "sliding" and "coulomb" contacts: a disk's 10-state x = (c1, c2, phi, theta, psi, dc1, dc2, dphi, dtheta, dpsi)
# through a control period, one mode at a time, to its switching events (contact_segment): the one implementation of
# the switching, which the env's steps (advance_contact) and simulate_contact (contact_run, and its scipy methods
# through contact_phase and sliding.stick) run.


@inline_kernel
def rolling_part(x):
    """The rolling 8-state ``(c1, c2, phi, theta, psi, dphi, dtheta, dpsi)`` of a 10-state."""
    return x[0], x[1], x[2], x[3], x[4], x[7], x[8], x[9]


@inline_kernel
def rolling_start(y, m, g, r):
    """The 10-state of a rolling 8-state ``y``: the centre's velocity from the rolling constraint, the slip zero."""
    dc1, dc2 = centre_velocity(y, kernels.angles(y), m, g, r)
    return y[0], y[1], y[2], y[3], y[4], dc1, dc2, y[5], y[6], y[7]


@inline_kernel
def along(x, a, k):
    """``x + a k`` for 10-tuples."""
    return (
        x[0] + a * k[0], x[1] + a * k[1], x[2] + a * k[2], x[3] + a * k[3], x[4] + a * k[4],
        x[5] + a * k[5], x[6] + a * k[6], x[7] + a * k[7], x[8] + a * k[8], x[9] + a * k[9],
    )  # fmt: skip


@inline_kernel
def hybrid_friction(x, mu, onset, reference, zero_slip, r):
    """The friction per unit normal force ``(f1, f2)`` of a sliding disk of the Coulomb hybrid.

    Where the slip speed exceeds ``zero_slip`` (m/s), the kinetic law ``-mu v / |v|``; but reversed where the slip
    points against ``reference`` (a direction, or zeros for none), so that an integration stage evaluated past a stop
    continues the friction of the approach instead of flipping it. At zero slip, ``onset``: the friction the rolling
    contact needed, at its limit mu.
    """
    v1, v2 = sliding.slip_velocity(x, r)
    if v1 * v1 + v2 * v2 <= zero_slip * zero_slip:
        return onset[0], onset[1]
    f1, f2 = sliding.kinetic_friction(v1, v2, mu)
    if v1 * reference[0] + v2 * reference[1] < 0.0:
        return -f1, -f2
    return f1, f2


@inline_kernel
def hybrid_slope(x, u, law, disk):
    """dx/dt of a sliding disk under the friction of :func:`hybrid_friction`, ``law = (mu, onset, reference,
    zero_slip)``; ``u`` the torques (N m), ``disk`` (m, g, r)."""
    mu, onset, reference, zero_slip = law
    f1, f2 = hybrid_friction(x, mu, onset, reference, zero_slip, disk[2])
    return sliding.friction_derivative(x, u[0], u[1], f1, f2, disk[0], disk[1], disk[2])


@inline_kernel
def rk4_combined(x, h, k1, k2, k3, k4):
    """The 10-state ``x`` advanced by ``h`` seconds along the classical Runge-Kutta combination of its four slopes."""
    slope = (
        k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0], k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1],
        k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2], k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3],
        k1[4] + 2 * k2[4] + 2 * k3[4] + k4[4], k1[5] + 2 * k2[5] + 2 * k3[5] + k4[5],
        k1[6] + 2 * k2[6] + 2 * k3[6] + k4[6], k1[7] + 2 * k2[7] + 2 * k3[7] + k4[7],
        k1[8] + 2 * k2[8] + 2 * k3[8] + k4[8], k1[9] + 2 * k2[9] + 2 * k3[9] + k4[9],
    )  # fmt: skip
    return along(x, h / 6, slope)


@kernel
def hybrid_rk4_step(x, k1, h, u, law, disk):
    """One classical Runge-Kutta step of ``h`` seconds of a sliding disk (see :func:`hybrid_slope`), ``k1`` its
    slope at ``x``."""
    k2 = hybrid_slope(along(x, h / 2, k1), u, law, disk)
    k3 = hybrid_slope(along(x, h / 2, k2), u, law, disk)
    k4 = hybrid_slope(along(x, h, k3), u, law, disk)
    return rk4_combined(x, h, k1, k2, k3, k4)


@inline_kernel
def rolling_margin(y, u, mu, disk):
    """``mu N - |lambda|`` of a rolling 8-state (N): positive while friction holds the contact."""
    _, lambda1, lambda2, normal = kernels.diagnostics(y, u[0], u[1], disk[0], disk[1], disk[2])
    return mu * normal - math.sqrt(lambda1 * lambda1 + lambda2 * lambda2)


@kernel
def margin_at(y, u, mu, disk):
    """:func:`rolling_margin`, a function of its own in the scalar paths."""
    return rolling_margin(y, u, mu, disk)


@kernel
def rolling_step(y, h, u, mu, disk):
    """``(y, margin)``: one RK4 step of ``h`` seconds of the rolling 8-state ``y`` and :func:`rolling_margin` there (a
    function of its own in the scalar paths, compiled once instead of written into each caller)."""
    moved = kernels.state_rk4_step(y, h, u[0], u[1], disk[0], disk[1], disk[2])
    return moved, rolling_margin(moved, u, mu, disk)


@kernel
def contact_phase(x, u, mu, coulomb, disk):
    """The mode of a disk in the 10-state ``x``: ``(code, rolling, law)``.

    A disk that slips (slip speed above ``ZERO_SLIP sqrt(g r)``), and every disk on the frozen lake (``"sliding"``
    with mu = 0), slides under kinetic friction (``law``'s reference: the slip's direction where mu > 0). At zero slip,
    the rolling contact's needs decide: the disk rolls where ``"coulomb"`` friction holds it, ``|lambda| <= mu N``;
    else it slides, starting with the friction it needed at its limit ``mu N`` (``law``'s onset). ``code`` is
    LIFTED_OFF where the normal force of a disk at zero slip vanishes, and OUT_OF_DOMAIN where a ``"sliding"`` disk
    with mu > 0 has zero slip and friction could hold it: the kinetic law has no force there (``"coulomb"`` rolls).
    """
    m, g, r = disk
    zero_slip = ZERO_SLIP * math.sqrt(g * r)
    v1, v2 = sliding.slip_velocity(x, r)
    speed = math.sqrt(v1 * v1 + v2 * v2)
    none = (0.0, 0.0)
    if speed > zero_slip or (mu == 0.0 and not coulomb):
        reference = (v1 / speed, v2 / speed) if mu > 0.0 and speed > zero_slip else none
        return RUNNING, False, (mu, none, reference, zero_slip)
    _, lambda1, lambda2, normal = kernels.diagnostics(rolling_part(x), u[0], u[1], m, g, r)
    need = math.sqrt(lambda1 * lambda1 + lambda2 * lambda2)
    if not normal > 0.0:
        return LIFTED_OFF, True, (mu, none, none, zero_slip)
    if need <= mu * normal:
        return (RUNNING if coulomb else OUT_OF_DOMAIN), True, (mu, none, none, zero_slip)
    onset = (mu * lambda1 / need, mu * lambda2 / need) if need > 0.0 else none
    return RUNNING, False, (mu, onset, none, zero_slip)


@inline_kernel
def slip_along(x, reference, r):
    """``v . reference``: the slip velocity (m/s) along a direction; it turns negative past a stop."""
    v1, v2 = sliding.slip_velocity(x, r)
    return v1 * reference[0] + v2 * reference[1]


@kernel
def sliding_energy(x, disk):
    """J. The kinetic plus potential energy of a 10-state."""
    return sliding.friction_diagnostics(x, 0.0, 0.0, 0.0, 0.0, disk[0], disk[1], disk[2])[0]


@inline_kernel
def normal_per_mass(x, slope, g, r):
    """m/s^2. ``N / m = g + c3''`` of a disk in the 10-state ``x`` moving as ``slope`` (dx/dt), the height of its
    centre being ``c3 = r cos(theta)``."""
    sin_theta, cos_theta = sincos(x[3])
    return g - r * (cos_theta * x[8] * x[8] + sin_theta * slope[8])


@inline_kernel
def slide_step_limit(x, slope, mu, disk):
    """s. The longest step a sliding disk in ``x`` moving as ``slope`` (dx/dt) takes near zero slip: :data:`TURN` of
    the time in which friction could turn its slip's direction, ``|v| / (5 mu N / m)`` (friction changes the slip at
    up to ``5 mu N / m``: 5 bounds the eigenvalues of the contact's ``m A M^-1 A^T``, 3 and ``5 / (1 + 4 sin^2
    theta)``); and where the slip slows, :data:`APPROACH` of the time to its stop at that rate, ``|v| / (-d|v|/dt)``.
    Near zero slip the kinetic law's direction is stiff, turning as fast as the speed falls: longer explicit steps
    lose it."""
    _, g, r = disk
    v1, v2 = sliding.slip_velocity(x, r)
    a1, a2 = sliding.slip_acceleration(x, slope, r)
    speed_squared = v1 * v1 + v2 * v2
    normal = normal_per_mass(x, slope, g, r)
    turn = TURN * math.sqrt(speed_squared) / (5.0 * mu * normal) if mu * normal > 0.0 else math.inf
    slowing = -(v1 * a1 + v2 * a2)
    return min(turn, APPROACH * speed_squared / slowing) if slowing > 0.0 else turn


NO_EVENT, SLIP, STICK, RESLIP = range(4)
"""Switching events (:func:`contact_segment`): none; the contact needed more friction than mu N and the disk starts
sliding; the slip stopped where friction holds the disk, which rolls again; the slip stopped where friction cannot
hold it, and the disk slides on in a new direction."""
TURN = 0.5
"""A step of a sliding disk takes at most this fraction of the time in which friction could turn its slip's direction
(:func:`slide_step_limit`). Measured on the paper's steady circle at mu = 0.2 (RK4, outputs every 0.001 s), the
stops came within 4e-8 s of DOP853's at rtol = 1e-12 with 0.2, 0.5 and 1; with 2 they came 7e-5 s off at outputs of
0.01 s."""
APPROACH = 0.5
"""A step of a sliding disk whose slip slows goes at most this fraction of the time to its stop at its rate of slowing
(:func:`slide_step_limit`): no step crosses the stop."""
EXPLICIT_FROM = 2e-6
"""s. Near zero slip the kinetic law's steps (:func:`slide_step_limit`) shrink with the slip: below this, a slide takes
steps with the slip's direction slaved instead (:func:`slaved_segment`), and every slide from zero slip starts so.
Measured on the paper's steady circle (RK4, outputs every 0.001 s), against DOP853 at rtol = 1e-12 with the kinetic
law throughout: the stops at mu = 0.2 and 0.3 came within 3e-8 s with 1e-6 and 1e-7 s with 3e-6, 3e-6 s with 1e-5 and
2.5e-4 s with 1e-4 (the slaved direction is the kinetic one only once the slip is small enough); a batch on task
circle under random torques at mu = 0.2 took 1.4, 1.1 and 0.7 us a disk-step with 1e-6, 3e-6 and 1e-4 (29 us with
the kinetic law's steps alone, down to zero slip)."""
MAX_SHORTENINGS = 60
"""Times a sliding step that went past a stop is shortened fourfold before it is taken as it is."""


@kernel
def slaved_slope(x, u, mu, disk, guess):
    """``(dx/dt, w)`` of a sliding disk whose slip is too small for its direction to lag behind friction.

    Kinetic friction ``-mu N v / |v|`` turns the slip's direction within ``|v| / (5 mu N / m)``, a time that vanishes
    with the slip: near zero slip the direction is slaved to a ``w`` along which the slip's rate of change ``a`` points
    under the friction ``-mu N w`` (``a(-mu w)`` parallel to ``w``: the slip shrinks along it to a stop, or grows along
    it from an onset). ``a(f) D(f)`` is affine in the friction per unit normal force ``f``, ``D = 5 - 4 cos^2 theta - 4
    sin theta cos theta f . (cos psi, sin psi)`` the normal force's denominator (``sliding.py``): three evaluations
    give it, and Newton's method finds the angle of ``w`` from the direction ``guess``."""
    m, g, r = disk
    sin_theta, cos_theta = sincos(x[3])
    sin_psi, cos_psi = sincos(x[4])
    lean, base = 4.0 * sin_theta * cos_theta, 5.0 - 4.0 * cos_theta * cos_theta
    a0 = sliding.slip_acceleration(x, sliding.friction_derivative(x, u[0], u[1], 0.0, 0.0, m, g, r), r)
    a1 = sliding.slip_acceleration(x, sliding.friction_derivative(x, u[0], u[1], 1.0, 0.0, m, g, r), r)
    a2 = sliding.slip_acceleration(x, sliding.friction_derivative(x, u[0], u[1], 0.0, 1.0, m, g, r), r)
    d1, d2 = base - lean * cos_psi, base - lean * sin_psi
    alpha = (a0[0] * base, a0[1] * base)
    b11, b21 = a1[0] * d1 - alpha[0], a1[1] * d1 - alpha[1]
    b12, b22 = a2[0] * d2 - alpha[0], a2[1] * d2 - alpha[1]
    norm = math.sqrt(guess[0] * guess[0] + guess[1] * guess[1])
    w = (guess[0] / norm, guess[1] / norm) if norm > 0.0 else (1.0, 0.0)
    for _ in range(SLAVED_ITERATIONS):
        # G(phi) = cross(alpha - mu B w, w) = 0 for w = (cos phi, sin phi); dw/dphi = (-w2, w1).
        bw = (b11 * w[0] + b12 * w[1], b21 * w[0] + b22 * w[1])
        bt = (b12 * w[0] - b11 * w[1], b22 * w[0] - b21 * w[1])
        value = (alpha[0] - mu * bw[0]) * w[1] - (alpha[1] - mu * bw[1]) * w[0]
        slope = alpha[0] * w[0] + alpha[1] * w[1] - mu * (bt[0] * w[1] - bt[1] * w[0] + bw[0] * w[0] + bw[1] * w[1])
        turn = min(max(-value / slope, -0.5), 0.5) if slope != 0.0 else 0.0
        sine, cosine = sincos(turn)
        w = (w[0] * cosine - w[1] * sine, w[0] * sine + w[1] * cosine)
        if abs(turn) < 1e-15:
            break
    return sliding.friction_derivative(x, u[0], u[1], -mu * w[0], -mu * w[1], m, g, r), w


SLAVED_ITERATIONS = 30
"""Newton steps :func:`slaved_slope` takes at most (from a nearby direction it needs a few)."""
SLAVED_ALIGNMENT = 0.9
"""A slip near zero slides with its direction slaved where the slaved direction found from its own is within this
cosine of it: where none is (the slip spirals in to its stop, turning as it slows), kinetic steps follow it."""


@kernel
def growing_direction(x, u, mu, disk, guess):
    """``(dx/dt, w, growth)``: :func:`slaved_slope` at zero slip from ``guess`` (against the onset's friction) and, if
    the slip does not grow along the direction found there, from ``guess`` turned by 90, 180 and 270 degrees, the
    first along which it grows: ``growth = w . dv/dt`` (m/s^2; <= 0 where it grows along none)."""
    r = disk[2]
    slope, w = slaved_slope(x, u, mu, disk, guess)
    a1, a2 = sliding.slip_acceleration(x, slope, r)
    best = (slope, w, w[0] * a1 + w[1] * a2)
    for turn in range(1, 4):
        if best[2] > 0.0:
            break
        cosine, sine = (1.0, 0.0, -1.0, 0.0)[turn], (0.0, 1.0, 0.0, -1.0)[turn]
        slope, w = slaved_slope(
            x, u, mu, disk, (guess[0] * cosine - guess[1] * sine, guess[0] * sine + guess[1] * cosine)
        )
        a1, a2 = sliding.slip_acceleration(x, slope, r)
        if w[0] * a1 + w[1] * a2 > best[2]:
            best = (slope, w, w[0] * a1 + w[1] * a2)
    return best


@kernel
def slaved_rk4_step(x, k1, w, h, u, mu, disk):
    """One classical Runge-Kutta step of ``h`` seconds of a sliding disk near zero slip (:func:`slaved_slope`), ``k1``
    its slope at ``x`` and ``w`` the direction there; each stage's direction found from the one before."""
    k2, w = slaved_slope(along(x, h / 2, k1), u, mu, disk, w)
    k3, w = slaved_slope(along(x, h / 2, k2), u, mu, disk, w)
    k4, _ = slaved_slope(along(x, h, k3), u, mu, disk, w)
    return rk4_combined(x, h, k1, k2, k3, k4)


@inline_kernel
def aligned(x, w, r):
    """``(x, s)``: the 10-state ``x`` with its slip turned onto the direction ``w`` by the contact impulse that takes
    the least energy, ``s w`` the slip it leaves: ``s = w^T W^-1 v / w^T W^-1 w`` (the projection in the metric of
    the kinetic energy, which the impulse can only lower, by ``|v - s w|^2 / 2`` in that metric). What friction does
    near zero slip in a time too short to resolve, as the slaved direction turns."""
    v1, v2 = sliding.slip_velocity(x, r)
    w11, w12, w22 = sliding.mobility(x, r)  # W^-1 is proportional to ((w22, -w12), (-w12, w11))
    metric_v = (w22 * v1 - w12 * v2, w11 * v2 - w12 * v1)
    metric_w = (w22 * w[0] - w12 * w[1], w11 * w[1] - w12 * w[0])
    s = (w[0] * metric_v[0] + w[1] * metric_v[1]) / (w[0] * metric_w[0] + w[1] * metric_w[1])
    return sliding.impulse(x, s * w[0] - v1, s * w[1] - v2, r), s


@kernel
def slide_segment(x, law, left, u, mu, coulomb, disk):
    """A sliding disk under kinetic friction (see :func:`contact_segment`): one RK4 step, of ``left`` or of what
    :func:`slide_step_limit` allows, shortened where it passes a stop; near zero slip (a limit below
    :data:`EXPLICIT_FROM`) and from zero slip, :func:`slaved_segment`."""
    _, g, r = disk
    reference = law[2]
    slows = reference[0] != 0.0 or reference[1] != 0.0  # kinetic friction on a slip: it may stop
    slope = hybrid_slope(x, u, law, disk)
    h = left
    if mu > 0.0 and slows:
        # Far from zero slip (the normal force bounded by N / m <= g + r (dtheta^2 + |ddtheta|)), a whole step.
        v1, v2 = sliding.slip_velocity(x, r)
        reach = 5.0 * mu * (g + r * (x[8] * x[8] + abs(slope[8]))) * left / TURN
        if v1 * v1 + v2 * v2 <= reach * reach:
            h = min(left, slide_step_limit(x, slope, mu, disk))
    if mu > 0.0 and not slows:  # from zero slip: along a slaved direction in which the slip grows
        slaved = growing_direction(x, u, mu, disk, (-law[1][0], -law[1][1]))
        if slaved[2] > 0.0:
            held, segment = slaved_segment(x, slaved[:2], law, left, u, mu, coulomb, disk)
            if held:
                return segment
        h = min(left, EXPLICIT_FROM)  # none: kinetic steps from the onset's friction
    if mu > 0.0 and h < EXPLICIT_FROM:  # near zero slip, slaved where the slip points along a slaved direction
        slaved = slaved_slope(x, u, mu, disk, reference)
        w = slaved[1]
        if w[0] * reference[0] + w[1] * reference[1] > SLAVED_ALIGNMENT:
            held, segment = slaved_segment(x, slaved, law, left, u, mu, coulomb, disk)
            if held:
                return segment
    for _ in range(MAX_SHORTENINGS):
        new = hybrid_rk4_step(x, slope, h, u, law, disk)
        if not slows or slip_along(new, reference, r) > 0.0:
            break
        h *= 0.25  # the slip turned back within the step: the stop is nearer than its rate of slowing said
    if mu == 0.0:  # the frozen lake: no friction, no events
        return new, False, law, h, RUNNING, NO_EVENT, 0.0, 0.0
    v1, v2 = sliding.slip_velocity(new, r)
    speed = math.sqrt(v1 * v1 + v2 * v2)
    return new, False, (mu, law[1], (v1 / speed, v2 / speed), law[3]), h, RUNNING, NO_EVENT, 0.0, 0.0


@kernel
def slaved_segment(x, slaved, law, left, u, mu, coulomb, disk):
    """A slide near zero slip (see :func:`contact_segment`): one step with the slip's direction slaved
    (``slaved``: :func:`slaved_slope` at ``x``), of ``left``, or while the slip slows at most :data:`APPROACH` of the
    time to its stop, the slip then aligned with the slaved direction (:func:`aligned`); where it falls below
    :data:`~rolling_disk_env.constants.STOP_SLIP` ``sqrt(g r)``, the stop. Returns ``(held, segment)``:
    :func:`contact_segment`'s return, and False where a slowing slip turned from the slaved direction even over the
    shortest step (then kinetic steps must follow it)."""
    _, g, r = disk
    v1, v2 = sliding.slip_velocity(x, r)
    speed = math.sqrt(v1 * v1 + v2 * v2)
    k1, w = slaved
    a1, a2 = sliding.slip_acceleration(x, k1, r)
    slowing = -(w[0] * a1 + w[1] * a2)  # the slip's rate of change along w, with the sign of a slowing
    h = left
    if speed > law[3] and slowing > 0.0:
        h = min(left, APPROACH * speed / slowing)
    elif slowing < 0.0:  # growing: no further than the slaved direction holds, where kinetic steps take over
        reach = EXPLICIT_FROM * 5.0 * mu * normal_per_mass(x, k1, g, r) / TURN
        h = min(left, max(reach - speed, 0.5 * reach) / -slowing)
    stop = STOP_SLIP * math.sqrt(g * r)
    for _ in range(MAX_SHORTENINGS):
        new = slaved_rk4_step(x, k1, w, h, u, mu, disk)
        _, direction = slaved_slope(new, u, mu, disk, w)
        new, slip = aligned(new, direction, r)
        if slip > -stop or slowing <= 0.0:
            break
        h *= 0.25  # past the stop: it came sooner than its rate of slowing said
    if slip > stop or (slowing <= 0.0 and slip > 0.0):
        return True, (new, False, (mu, law[1], direction, law[3]), h, RUNNING, NO_EVENT, 0.0, 0.0)
    if slip <= 0.0 and slowing <= 0.0:  # the slip has not grown from zero: on under the friction of its onset
        return True, (new, False, law, h, RUNNING, NO_EVENT, 0.0, 0.0)
    stuck = sliding.stick(new, r)
    change = sliding_energy(stuck, disk) - sliding_energy(new, disk)
    code, rolling, law = contact_phase(stuck, u, mu, coulomb, disk)
    return slip > -stop, (stuck, rolling, law, h, code, (STICK if rolling else RESLIP), abs(slip), change)


@kernel
def contact_segment(x, rolling, law, left, u, mu, coulomb, disk):
    """A disk's 10-state ``x`` in its mode (``rolling``, or sliding under ``law``: :func:`contact_phase`) for up to
    ``left`` seconds, to its first switching event. Torques ``u`` (N m), disk ``(m, g, r)``.

    Rolling: one RK4 step of the rolling model; where ``mu N - |lambda|`` changes sign within it, the step is cut by
    bisection where it vanishes (to :data:`~rolling_disk_env.constants.EVENT_TIME_TOLERANCE`), and the disk starts
    sliding with the friction it needed there (SLIP).

    Sliding (:func:`slide_segment`): one RK4 step of the sliding model under kinetic friction, of ``left``, but near
    zero slip no longer than :func:`slide_step_limit` allows, so that the steps follow the slip's direction as it
    turns; closer to zero slip, and from zero slip, a step with the direction slaved (:func:`slaved_segment`), which
    closes in on a stop. Where the slip speed falls below :data:`~rolling_disk_env.constants.STOP_SLIP` ``sqrt(g r)``,
    the slide ends: the contact impulse (``sliding.stick``) zeroes the slip, and the disk rolls (STICK) or slides on
    from zero slip (RESLIP), as :func:`contact_phase` decides.

    Returns:
        ``(x, rolling, law, used, code, kind, slip, change)``: the 10-state and mode after the segment, the seconds
        it took, :func:`contact_phase`'s code after an event (else RUNNING), the event (NO_EVENT, SLIP, STICK or
        RESLIP), and at a stop the slip speed before the impulse (m/s) and the energy the impulse changed (J, <= 0).
    """
    m, g, r = disk
    if rolling:
        y = rolling_part(x)
        before = margin_at(y, u, mu, disk)
        moved, after = rolling_step(y, left, u, mu, disk)
        if not (before > 0.0 >= after):
            return rolling_start(moved, m, g, r), True, law, left, RUNNING, NO_EVENT, 0.0, 0.0
        low, high = 0.0, left
        while high - low > EVENT_TIME_TOLERANCE:
            middle = 0.5 * (low + high)
            probe, margin = rolling_step(y, middle, u, mu, disk)
            if margin > 0.0:
                low = middle
            else:
                high, moved = middle, probe
        _, lambda1, lambda2, _ = kernels.diagnostics(moved, u[0], u[1], m, g, r)
        need = math.sqrt(lambda1 * lambda1 + lambda2 * lambda2)
        onset = (mu * lambda1 / need, mu * lambda2 / need)
        return rolling_start(moved, m, g, r), False, (mu, onset, law[2], law[3]), high, RUNNING, SLIP, 0.0, 0.0
    return slide_segment(x, law, left, u, mu, coulomb, disk)


@inline_kernel
def in_model(x):
    """Whether a 10-state is finite and within the model's domain ``|theta| < LEAN_LIMIT``."""
    total = x[0] + x[1] + x[2] + x[3] + x[4] + x[5] + x[6] + x[7] + x[8] + x[9]
    return math.isfinite(total) and abs(x[3]) < LEAN_LIMIT


MAX_PERIOD_SWITCHES = 1000
"""Switching events a disk may take in one control period under the ``"coulomb"`` contact; past it the episode ends
with ``SUBSTEP_LIMIT`` (stick-slip chattering)."""
MAX_PERIOD_SEGMENTS = 100_000
"""Integration steps (:func:`contact_segment`) a disk may take in one control period; past it the episode ends with
``SUBSTEP_LIMIT``."""


@kernel
def advance_contact(x, period, substeps, u, mu, coulomb, disk):
    """A disk's 10-state ``x`` through a control period of ``substeps`` steps under the ``"sliding"`` (``coulomb``
    False) or the ``"coulomb"`` contact of coefficient ``mu``, torques ``u`` (N m), disk ``(m, g, r)``: the mode of
    :func:`contact_phase`, then :func:`contact_segment` to each switching event and on.

    Returns:
        ``(x, code, report)``: the 10-state at the end of the period and RUNNING; or the state at its start and
        OUT_OF_DOMAIN (the state left the model's domain, or :func:`contact_phase` says so), LIFTED_OFF, or
        SUBSTEP_LIMIT (more than :data:`MAX_PERIOD_SWITCHES` switches or :data:`MAX_PERIOD_SEGMENTS` steps); and what
        the disk reports there (:func:`mode_contact`, in the mode it ended in).
    """
    start = x
    code, rolling, law = contact_phase(x, u, mu, coulomb, disk)
    switches = segments = 0
    for _ in range(substeps):
        left = period / substeps
        while code == RUNNING and left > 0.0:
            x, rolling, law, used, code, kind, _, _ = contact_segment(x, rolling, law, left, u, mu, coulomb, disk)
            left = left - used if used < left else 0.0
            switches += kind != NO_EVENT
            segments += 1
            if not in_model(x):
                code, x = OUT_OF_DOMAIN, start
            elif switches > MAX_PERIOD_SWITCHES or segments > MAX_PERIOD_SEGMENTS:
                code = SUBSTEP_LIMIT
    if code == OUT_OF_DOMAIN:
        x = start
        _, rolling, law = contact_phase(x, u, mu, coulomb, disk)
    return x, code, mode_contact(x, u, rolling, law, disk)


EVENT_SIZE = 14
"""Columns of an event row of :func:`contact_run`: time (s), kind (:data:`SLIP`, :data:`STICK`, :data:`RESLIP`),
the slip speed before the stop's impulse (m/s), the energy the impulse changed (J), then the 10-state after it."""


@kernel
def contact_run(x, times, torques, mu, coulomb, disk, rolled, states, events):
    """``simulate_contact``'s ``"rk4"``: a disk's 10-state ``x`` through the intervals between ``times`` (s), each
    one RK4 step (:func:`contact_segment` to each event), under the torques of its row of ``torques`` (N m).

    The states at ``times`` go into the rows of ``states``, and the switching events into the rows of ``events``
    (:data:`EVENT_SIZE` columns) while they fit. Each interval starts in the mode :func:`contact_phase` gives with its
    torque: a disk that rolled (``rolled``, for the first) and needs more friction than mu there slips (an event).

    Returns:
        ``(count, code, time, switches, rolling)``: the states written at ``times``, RUNNING or the code that stopped
        the run (OUT_OF_DOMAIN, LIFTED_OFF, SUBSTEP_LIMIT: more events than ``events`` holds, or more than
        :data:`MAX_PERIOD_SEGMENTS` steps in an interval; then the state where it stopped is in row ``count``), the
        time reached (s), the events, and whether the disk rolls at the end.
    """
    r = disk[2]
    store(states[0], x)
    switches = 0
    rolling = rolled
    for k in range(1, times.shape[0]):
        t, left = times[k - 1], times[k] - times[k - 1]
        u = (torques[k - 1, 0], torques[k - 1, 1])
        code, now, law = contact_phase(x, u, mu, coulomb, disk)
        v1, v2 = sliding.slip_velocity(x, r)
        if rolling and code == RUNNING and not now and v1 * v1 + v2 * v2 <= law[3] * law[3] and (coulomb or mu > 0):
            if switches < events.shape[0]:
                events[switches, 0], events[switches, 1], events[switches, 2], events[switches, 3] = t, SLIP, 0, 0
                store(events[switches, 4:], x)
            switches += 1
        rolling, segments = now, 0
        while code == RUNNING and left > 0.0:
            x, rolling, law, used, code, kind, slip, change = contact_segment(
                x, rolling, law, left, u, mu, coulomb, disk
            )
            t, left = (t + used, left - used) if used < left else (times[k], 0.0)
            segments += 1
            if not in_model(x):
                code = OUT_OF_DOMAIN
                break
            if kind != NO_EVENT:
                if switches < events.shape[0]:
                    events[switches, 0], events[switches, 1], events[switches, 2] = t, kind, slip
                    events[switches, 3] = change
                    store(events[switches, 4:], x)
                switches += 1
            if switches > events.shape[0] or segments > MAX_PERIOD_SEGMENTS:
                code = SUBSTEP_LIMIT
        if code == RUNNING and not hybrid_contact(x, u, mu, coulomb, disk)[3] > 0.0:
            code = LIFTED_OFF
        store(states[k], x)
        if code != RUNNING:
            return k, code, t, switches, rolling
    return times.shape[0], RUNNING, times[-1], switches, rolling


@kernel
def hybrid_contact(x, u, mu, coulomb, disk):
    """What a disk in the 10-state ``x`` reports under the ``"sliding"`` or ``"coulomb"`` contact (in the mode of
    :func:`contact_phase`): see :func:`mode_contact`."""
    _, rolling, law = contact_phase(x, u, mu, coulomb, disk)
    return mode_contact(x, u, rolling, law, disk)


@inline_kernel
def mode_contact(x, u, rolling, law, disk):
    """What a disk in the 10-state ``x``, rolling or sliding under ``law``, reports:
    ``(energy, F1, F2, normal_force, required_friction, v1, v2, sliding)``: J, the horizontal and vertical ground
    reactions (N), the friction coefficient the contact uses (``|F| / N``: what it needs while it rolls; mu, or the
    onset's, while it slides; inf where N <= 0), the slip velocity (m/s: zeros while it rolls) and 1.0 where the disk
    slides (0.0 where it rolls)."""
    m, g, r = disk
    if rolling:
        energy, force1, force2, normal, required = contact(rolling_part(x), u[0], u[1], m, g, r)
        return energy, force1, force2, normal, required, 0.0, 0.0, 0.0
    energy, normal, force1, force2, v1, v2 = hybrid_diagnostics(x, u, law[0], law[1], law[2], law[3], disk)
    required = math.sqrt(force1 * force1 + force2 * force2) / normal if normal > 0.0 else math.inf
    return energy, force1, force2, normal, required, v1, v2, 1.0


@inline_kernel
def contact_start(x, velocity, mu, coulomb, disk):
    """A disk starting in the rolling 8-state ``x`` under the ``"sliding"`` or ``"coulomb"`` contact: its 10-state,
    the centre's velocity ``velocity`` (m/s; NaNs: from the rolling constraint), and its :func:`hybrid_contact` at zero
    torque."""
    state = rolling_start(x, disk[0], disk[1], disk[2])
    if not math.isnan(velocity[0]):
        state = (
            state[0],
            state[1],
            state[2],
            state[3],
            state[4],
            velocity[0],
            velocity[1],
            state[7],
            state[8],
            state[9],
        )
    return state, hybrid_contact(state, (0.0, 0.0), mu, coulomb, disk)


@inline_kernel
def in_domain8(x):
    """Whether an 8-state is finite and within the model's domain ``|theta| < LEAN_LIMIT``."""
    total = x[0] + x[1] + x[2] + x[3] + x[4] + x[5] + x[6] + x[7]
    return math.isfinite(total) & (abs(x[3]) < LEAN_LIMIT)


@inline_kernel
def marked(slides, x, tau_spin, tau_steer, mu, coulomb, m, g, r):
    """1.0 where a disk of a ``"sliding"`` or ``"coulomb"`` step must go through the hybrid (``slides``: already
    marked, or sliding), or where at the rolling 8-state ``x`` it leaves the model's domain or friction does not hold
    it, ``mu N - |lambda| <= 0`` (every disk under ``"sliding"``); else 0.0 (branch-free)."""
    margin = rolling_margin(x, (tau_spin, tau_steer), mu, (m, g, r))
    holding = (slides == 0.0) & coulomb & in_domain8(x) & (margin > 0.0)  # no branch: the loop vectorizes
    return 0.0 if holding else 1.0


@inline_kernel
def holds(slides, x, contact, mu, coulomb):
    """Whether a disk of a ``"coulomb"`` step rolled through the period: not marked (``slides`` 0.0), in the domain
    at its end ``x`` and held there by friction, ``mu N - |lambda| > 0`` (``contact`` is :func:`contact`'s report)."""
    margin = mu * contact[3] - math.sqrt(contact[1] * contact[1] + contact[2] * contact[2])
    return (slides == 0.0) & coulomb & in_domain8(x) & (margin > 0.0)


@kernel
def sliding_derivatives(states, torques, frictions, disks, out):
    """dx/dt of the sliding model under kinetic friction for each row of 10-states; ``frictions[i]`` is row i's
    coefficient, ``torques`` rows (tau_spin, tau_steer) (N m), ``disks`` rows (m, g, r)."""
    for i in range(states.shape[0]):
        u, disk = torques[i], disks[i]
        store(out[i], sliding.sliding_derivative(states[i], u[0], u[1], frictions[i], disk[0], disk[1], disk[2]))


@kernel
def sliding_diagnostics(states, torques, frictions, disks, out):
    """``(energy, normal_force, F1, F2, v1, v2)`` under kinetic friction for each row: ``out`` (N, 6)."""
    for i in range(states.shape[0]):
        u, disk = torques[i], disks[i]
        store(out[i], sliding.sliding_diagnostics(states[i], u[0], u[1], frictions[i], disk[0], disk[1], disk[2]))


@kernel
def hybrid_derivative(x, u, mu, onset, reference, zero_slip, disk, out):
    """dx/dt of a sliding disk of the Coulomb hybrid (friction from :func:`hybrid_friction`) into ``out`` (10,)."""
    store(out, hybrid_slope(x, u, (mu, onset, reference, zero_slip), disk))


@kernel
def hybrid_diagnostics(x, u, mu, onset, reference, zero_slip, disk):
    """``(energy, normal_force, F1, F2, v1, v2)`` of a sliding disk of the Coulomb hybrid."""
    f1, f2 = hybrid_friction(x, mu, onset, reference, zero_slip, disk[2])
    energy, normal, v1, v2 = sliding.friction_diagnostics(x, u[0], u[1], f1, f2, disk[0], disk[1], disk[2])
    return energy, normal, normal * f1, normal * f2, v1, v2


# The model API's loops (rolling_disk_env.dynamics and rolling_disk_env.integrators): rows of states, torques (N, 2)
# and disks (N, 3) = (m, g, r).


@kernel
def store(row, values):
    """Writes a tuple of floats into an array row."""
    for j in range(len(values)):
        row[j] = values[j]


@kernel
def derivatives(states, torques, disks, out):
    """dx/dt of the full model (rows of 8) or dy/dt of the lean model (rows of 4) for each row."""
    lean = states.shape[1] == 4
    for i in range(states.shape[0]):
        u, disk = torques[i], disks[i]
        if lean:
            store(out[i], kernels.lean_derivative(states[i], u[0], u[1], disk[0], disk[1], disk[2]))
        else:
            store(out[i], kernels.state_derivative(states[i], u[0], u[1], disk[0], disk[1], disk[2]))


@kernel
def diagnostics(states, torques, disks, out):
    """:func:`contact` for each row of full states: ``out`` (N, 5)."""
    for i in range(states.shape[0]):
        u, disk = torques[i], disks[i]
        values = contact(states[i], u[0], u[1], disk[0], disk[1], disk[2])
        for j in range(5):
            out[i, j] = values[j]


@kernel
def _full_step(method, x, dt, u0, u1, m, g, r):
    if method == 0:
        return kernels.state_euler_step(x, dt, u0, u1, m, g, r)
    if method == 1:
        return kernels.state_symplectic_euler_step(x, dt, u0, u1, m, g, r)
    return kernels.state_rk4_step(x, dt, u0, u1, m, g, r)


@kernel
def _lean_step(method, y, dt, u0, u1, m, g, r):
    if method == 0:
        return kernels.lean_euler_step(y, dt, u0, u1, m, g, r)
    if method == 1:
        return kernels.lean_symplectic_euler_step(y, dt, u0, u1, m, g, r)
    return kernels.lean_rk4_step(y, dt, u0, u1, m, g, r)


@kernel
def advance(method, states, torques, disks, dt, sizes, rtol, atol, status):
    """Advances each row of ``states`` (full or lean model) by ``dt`` seconds with the integrator ``method`` (a code):
    one fixed step, or dopri5 steps under the tolerances from the step sizes ``sizes`` (updated). ``status`` gets
    OUT_OF_DOMAIN for a row that left the model's domain, SUBSTEP_LIMIT for one dopri5 gave up on, else RUNNING."""
    lean = states.shape[1] == 4
    for i in range(states.shape[0]):
        u0, u1, m, g, r, x = torques[i, 0], torques[i, 1], disks[i, 0], disks[i, 1], disks[i, 2], states[i]
        ok = True
        if lean:
            y = (x[0], x[1], x[2], x[3])
            if method == ADAPTIVE:
                y, sizes[i], ok = lean_advance_adaptive(y, dt, sizes[i], u0, u1, m, g, r, rtol, atol)
            else:
                y = _lean_step(method, y, dt, u0, u1, m, g, r)
            store(x, y)
        else:
            state = (x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7])
            if method == ADAPTIVE:
                state, sizes[i], ok = advance_adaptive(state, dt, sizes[i], u0, u1, m, g, r, rtol, atol)
            else:
                state = _full_step(method, state, dt, u0, u1, m, g, r)
            store(x, state)
        theta = x[0] if lean else x[3]
        finite = math.isfinite(np.sum(x))
        status[i] = SUBSTEP_LIMIT if not ok else (RUNNING if finite and abs(theta) < LEAN_LIMIT else OUT_OF_DOMAIN)
