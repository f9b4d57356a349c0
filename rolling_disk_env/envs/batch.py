"""N disks in the engine's arrays, stepped and reset by their task's compiled kernels: what both envs run.

The single env is a batch of one; the vector env a batch of N. Both call the same generated kernels
(``_generated/<task>.py``), so the same seeds give the same transitions to the last bit.

Layout: a batch's arrays have a column per disk (``lanes[row, i]``), split into *shares* of equal width, one per
thread, each padded (:func:`columns`): the step sees them as ``[row, k, i]`` for disk i of share k. The disks fill
the shares from the first, so the last share holds up to 16 (threads - 1) fewer disks than the others, and
padding columns are idle disks at rest, stepped but never reported.

Threads: a batch of at least :data:`THREADS_FROM` disks is split into one share per numba thread
(``NUMBA_NUM_THREADS``, by default one per core: :func:`thread_count`); smaller batches, and every batch in a child
process (``SubprocVecEnv``'s, whose siblings share the cores) or where ``NUMBA_NUM_THREADS=1``, have one share,
stepped on the calling thread. A batch of several shares steps them at once on the threads, or one after the other on
the calling thread, whichever its recent steps measured faster (:class:`ThreadChoice`): on idle cores the threads
win, but where another process keeps a core busy, the thread on that core is preempted for whole time slices and the
step waits for it. The disks of a share are independent of the others, so neither the shares nor the threads change
a result. Resets run the way the steps do.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import importlib
import logging
import math
import multiprocessing
import os
import platform
import time
from pathlib import Path
from types import ModuleType

import numba
import numpy as np

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None

from rolling_disk_env import engine
from rolling_disk_env.constants import set_suffix
from rolling_disk_env.dynamics import ROLLING_INDICES
from rolling_disk_env.envs.config import DRAWN, EnvConfig
from rolling_disk_env.jit import first_class
from rolling_disk_env.tasks.base import Task

GIVEN_SIZE = 10
"""Columns of the initial states a reset takes (``engine.ResetArrays.given``): the 8-state, then the centre's
velocity (m/s; NaN: from the rolling constraint, which the ``"rolling"`` contact always takes)."""


def given_states(states: np.ndarray) -> np.ndarray:
    """Initial states, (N, 8) rolling states or (N, 10) sliding states (:data:`rolling_disk_env.SLIDING_STATE_NAMES`),
    as a reset takes them: (N, :data:`GIVEN_SIZE`), the 8-state then the centre's velocity."""
    given = np.full((states.shape[0], GIVEN_SIZE), np.nan)
    if states.shape[1] == 8:
        given[:, :8] = states
    else:
        given[:, :8], given[:, 8:] = states[:, list(ROLLING_INDICES)], states[:, 5:7]
    return given


THREADS_FROM = 2048
"""Batches of this many disks or more step on several threads (``benchmarks/bench_env.py`` measures the threaded
step against the serial one around it)."""


def task_steps(task: Task) -> ModuleType:
    """The generated steps of a task (``_generated/<name>.py``, or those of the task it runs the steps of:
    ``Task.steps_of``), checked against the source of the task module they were generated from and against the task's
    layout (its reward terms and observation).

    Raises:
        RuntimeError: the task module changed since its steps were generated, they were never generated, or they lay
            out another number of reward terms or observations.
    """
    from rolling_disk_env.tasks import TASKS

    regenerate = "run `python -m rolling_disk_env.codegen`"
    name = task.steps_name
    try:
        steps = importlib.import_module(f"rolling_disk_env._generated.{name}")
    except ModuleNotFoundError:
        raise RuntimeError(f"task {name!r} has no generated steps: {regenerate}") from None
    if steps.TASK_SOURCE != TASKS[name].source_hash():
        raise RuntimeError(f"task {name!r} changed since its steps were generated: {regenerate}")
    terms, observations = steps.OBSERVATION - engine.TERMS, steps.OBSERVATION_SIZE
    if (len(task.reward_weights), len(task.observation_names)) != (terms, observations):
        raise RuntimeError(
            f"task {task.name!r} runs the steps of {name!r}, which write {terms} reward terms and {observations} "
            "observations: another number than the task's"
        )
    return steps


class ThreadChoice:
    """Chooses, step by step, whether a batch of several shares steps them on numba's threads or one after the other
    on the calling thread, from the times of its own recent steps.

    Only a step that follows a step of the same way is timed. The first after a change may compile; after a spell on the
    calling thread, numba's threads have gone to sleep and the first threaded step waits for them to wake (measured:
    probes of one step timed the threads at 1.5 times their steady step, at N = 4096, and kept on the calling thread a
    batch that the threads step twice as fast); after a spell on the threads, the first serial step finds half the disks
    in the other core's cache. The first steps try each way as a probe does (the losing way's steps are a lost probe's
    cost). Then the faster way is used, its time a moving average of its steps (weight :data:`WEIGHT` on the latest, a
    step counted at most twice the average: one step held up by the machine, a vCPU descheduled for some milliseconds,
    does not switch ways; a load that lasts does, within a few steps). Now and then :data:`PROBE_STEPS` steps try the
    other way (a probe), whose time the fastest of them sets (a single step held up would misjudge it), so that a change
    of load (another process starting or ending on the cores) is followed.

    A probe that loses costs the time its steps took beyond the way in use, and that cost sets when the next comes: at
    most :data:`BUDGET` of the time spent stepping goes to lost probes. Idle, a serial probe loses a fraction of a
    step and comes back every hundred steps or so; beside a busy core, a thread is preempted for whole time slices
    and a threaded probe loses some 14 ms, seventy serial steps (N = 4096, ``benchmarks/bench_threads.py``), so the
    next comes thousands of steps later. After a probe that wins, the ways swap and the next probe comes
    :data:`PROBE_EVERY` steps later.

    Attributes:
        threaded: whether the latest choice was the threads.
    """

    PROBE_EVERY = 32
    """Steps from a change of way to the first probe of the other, and the fewest between two probes."""
    PROBE_AT_MOST = 16384
    """The most steps between two probes."""
    PROBE_STEPS = 3
    """Steps of a probe: the first untimed, the faster of the others its time."""
    BUDGET = 0.02
    """The most of the stepping time that lost probes take."""
    WEIGHT = 0.25
    """Weight of a step's time in its way's moving average."""

    def __init__(self):
        self.threaded = True
        self.steps = 0
        self.next_probe = 2 * self.PROBE_STEPS + self.PROBE_EVERY
        self.seconds = [math.nan, math.nan]
        """Moving averages of a step's time (s): on the calling thread, on the threads."""
        self._last: bool | None = None  # the way of the latest step
        self._probe = math.inf  # the fastest timed step of the probe under way (s)
        self._spent = 0.0  # the time of the steps of the probe under way (s)
        self._start_spent = [0.0, 0.0]  # the time of the start's steps (s): on the calling thread, on the threads

    def next(self) -> bool:
        """Whether the next step runs on the threads."""
        self.steps += 1
        if self.steps <= 2 * self.PROBE_STEPS:  # the start: a probe of each way
            return self.steps > self.PROBE_STEPS
        return self.threaded != (self.next_probe <= self.steps < self.next_probe + self.PROBE_STEPS)

    def record(self, threaded: bool, seconds: float) -> None:
        """Takes the time of a step that ran on the threads or not."""
        follows, self._last = self._last == threaded, threaded
        start = self.steps <= 2 * self.PROBE_STEPS  # a probe of each way
        if start:  # a step of the start's probe of each way
            self._start_spent[threaded] += seconds
        elif threaded != self.threaded:  # a step of a probe: what it costs
            self._spent += seconds
        if not follows:  # the first step of a way
            return
        probe_ends = False
        if start or threaded != self.threaded:  # a timed step of a probe
            self._probe = min(self._probe, seconds)
            first = 1 + self.PROBE_STEPS * threaded if start else self.next_probe
            if self.steps < first + self.PROBE_STEPS - 1:
                return
            self.seconds[threaded], self._probe, probe_ends = self._probe, math.inf, True
            if start:
                if threaded:  # both tried: the losing way's steps are a lost probe's
                    self.threaded = self.seconds[True] < self.seconds[False]
                    self._schedule(self._start_spent[not self.threaded], self.PROBE_STEPS)
                return
        else:
            average = self.seconds[threaded]
            self.seconds[threaded] += self.WEIGHT * (min(seconds, 2.0 * average) - average)
        was = self.threaded
        self.threaded = self.seconds[True] < self.seconds[False]
        if self.threaded != was:  # a probe won, or the way in use slowed down past the other's last time
            self._schedule(0.0, 0)
        elif probe_ends:  # lost, after the steps from next_probe to this one
            self._schedule(self._spent, self.steps - self.next_probe + 1)

    def _schedule(self, spent: float, taken: int) -> None:
        """Sets the next probe after a probe of ``taken`` steps that took ``spent`` seconds in all lost (or after the
        start, whose losing way's steps are such a probe), or after a change of way (``taken`` 0): enough steps later
        that the probe's cost, beyond as many steps of the way in use, is :data:`BUDGET` of the time between."""
        step = self.seconds[self.threaded]
        cost = spent - taken * step
        self.next_probe = self.steps + min(
            max(self.PROBE_EVERY, math.ceil(cost / (self.BUDGET * step))), self.PROBE_AT_MOST
        )
        self._spent = 0.0


logger = logging.getLogger(__name__)
"""Where a batch says that it compiles its kernels (INFO): a line before, naming what and for which CPU, and one
after, with the seconds it took. Nothing where the kernels come from numba's cache."""


def cpu_name() -> str:
    """The CPU numba compiles for, and its widest vector extension: e.g. ``znver4, AVX-512``."""
    import llvmlite.binding

    name = numba.config.CPU_NAME or llvmlite.binding.get_host_cpu_name()
    features = numba.config.CPU_FEATURES or llvmlite.binding.get_host_cpu_features().flatten()
    flags = {feature.lstrip("+") for feature in features.split(",") if not feature.startswith("-")}
    return f"{name}, {'AVX-512' if 'avx512f' in flags else 'AVX2' if 'avx2' in flags else 'SSE2'}"


def in_disk_cache(kernel, signature: tuple) -> bool:
    """Whether numba's on-disk cache holds ``kernel`` compiled for the argument types ``signature`` (what
    ``Dispatcher.compile`` loads instead of compiling; False where it cannot tell)."""
    cache = getattr(kernel, "_cache", None)
    try:
        key = cache._index_key(signature, kernel.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except (AttributeError, OSError):  # no cache (numba's NullCache), or an index that cannot be read
        return False


def entry_point(kernel, args: tuple, name: str = "a kernel"):
    """The compiled function of ``kernel`` for the types of ``args``, to call with arguments of those types.

    A call through numba's dispatcher first types every argument to choose the compiled function: the arrays of a
    batch, in tuples, took a fifth of a single env's step that way (measured: a step's kernel called through the
    dispatcher 3.3 us, the compiled function 1.9 us; the batch's arrays now travel in a
    :class:`~rolling_disk_env.engine.Bundle`). A batch calls its step with arrays of the same types at every step, so
    it looks the function up once: ``Dispatcher.compile`` returns the one compiled or cached for the types (compiling
    it where there is none, which :data:`logger` says, naming it ``name``). Where numba's JIT is disabled
    (``NUMBA_DISABLE_JIT=1``), the kernel itself.
    """
    return compiled([(kernel, args)], name)[0]


def compiled(calls: list[tuple], name: str) -> list:
    """The compiled functions of ``calls``, pairs ``(kernel, args)`` (see :func:`entry_point`), compiling those that
    neither this process nor numba's cache on disk holds, under one log line naming them ``name``."""
    signatures = [
        tuple(kernel.typeof_pyval(arg) for arg in args) if hasattr(kernel, "compile") else None
        for kernel, args in calls
    ]
    missing = [
        (kernel, signature)
        for (kernel, _), signature in zip(calls, signatures)
        if signature is not None and signature not in kernel.overloads and not in_disk_cache(kernel, signature)
    ]
    if missing:
        kernel, signature = missing[0]
        where = getattr(kernel._cache, "_cache_path", None)
        with _compiling(where, f"{kernel.__qualname__}{signature}"):
            if not all(in_disk_cache(kernel, signature) for kernel, signature in missing):
                logger.info(
                    "compiling %s for this CPU (%s), once: it takes seconds to a minute; %s",
                    name,
                    cpu_name(),
                    f"cached in {where}" if where else "not cached (no writable cache directory)",
                )
                start = time.perf_counter()
                for kernel, signature in missing:
                    kernel.compile(signature)
                logger.info("compiled %s in %.1f s", name, time.perf_counter() - start)
    return [
        kernel if signature is None else kernel.compile(signature) for (kernel, _), signature in zip(calls, signatures)
    ]


@contextlib.contextmanager
def _compiling(directory: str | None, key: str):
    """Holds a lock file of ``key`` in the cache ``directory`` while a kernel compiles, so that processes starting
    the same configuration at once (pytest-xdist's workers, ``SubprocVecEnv``'s) compile it once: the others wait,
    then load it from the cache. Where there is no cache or no ``fcntl`` (Windows), no lock."""
    if directory is None or fcntl is None:
        yield
        return
    path = Path(directory) / f"compiling-{hashlib.sha256(key.encode()).hexdigest()[:16]}.lock"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(path, "a")
    except OSError:
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def thread_count(num_envs: int) -> int:
    """Threads that step a batch of ``num_envs`` disks: 1 below :data:`THREADS_FROM` and in a child process of
    ``multiprocessing``, else numba's thread count."""
    if num_envs < THREADS_FROM or multiprocessing.parent_process() is not None:
        return 1
    return numba.get_num_threads()


_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
"""glibc's mallopt parameter numbers."""
HEAP_FROM = 1024
"""Batches of this many disks or more make the process keep freed memory (:func:`keep_freed_memory`)."""


@functools.cache
def keep_freed_memory() -> bool:
    """Asks glibc's malloc to serve allocations up to 64 MiB from the heap and to keep up to 128 MiB of freed heap.

    Every step returns fresh arrays (the info block is 3 MB at N = 16384). By default glibc maps large allocations
    afresh and unmaps them when freed, so each step page-faults its outputs back in: measured at N = 16384
    (``circle``), a step took 3.3 ms instead of 1.6 ms. This sets ``M_MMAP_THRESHOLD`` and ``M_TRIM_THRESHOLD`` (what
    the environment variables ``MALLOC_MMAP_THRESHOLD_`` and ``MALLOC_TRIM_THRESHOLD_`` set, which are left alone if
    the user set either) once per process; elsewhere than glibc it does nothing. Returns whether it was set.
    """
    if {"MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"} & os.environ.keys() or platform.libc_ver()[0] != "glibc":
        return False
    try:
        libc = ctypes.CDLL(None)
        return bool(libc.mallopt(_M_MMAP_THRESHOLD, 64 * 2**20) and libc.mallopt(_M_TRIM_THRESHOLD, 128 * 2**20))
    except (OSError, AttributeError):
        return False


def columns(num_envs: int) -> int:
    """Columns of a share of ``num_envs`` disks: ``num_envs``, and from 256 disks on a few more (idle, never
    reported), so that a row of the share spans an odd number of 64-byte cache lines. With rows of a power-of-two
    size, the dozens of rows a step reads and writes map to the same sets of the CPU's cache and evict each other:
    measured at N = 4096 and 16384, a step took 31 to 37 ns a disk against 27 at N = 4104 and 16392. (A row of the
    whole batch spans threads times that: even with 2 threads, whose two halves were measured to keep the gain.)"""
    if num_envs < 256:
        return num_envs
    lines = -(-num_envs // 8)
    return 8 * (lines + 1 - lines % 2)


class Outputs:
    """What a step or a reset returns for N disks.

    Attributes:
        observations: (N, observation size), float32, clipped to the observation space.
        info: (engine.TERMS + terms + observation size (+ 5), N), float64, a column per disk: the state, energy,
            contact forces, normal force, required friction, reward, reward terms (rows ``engine.ENERGY`` and the
            others), then the observation (which the step copies into ``observations``), then under the
            ``"sliding"`` and ``"coulomb"`` contacts the rows ``engine.SLIDING_INFO``.
        flags: (3, N), bool, a column per disk: terminated, truncated, success (rows ``engine.TERMINATED`` and the
            others).
        codes: (N,), int64, the termination codes (``engine.RUNNING`` where the episode goes on).
        blocks: the arrays these are views of, as the reset takes them (padding included: a column or a row per
            column of the batch, :func:`columns`).
        shares: the same, as the step takes them: split into the batch's shares (``[row, k, i]``, ``[k, i, j]``).
    """

    def __init__(self, num_envs: int, shares: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]):
        """
        Args:
            num_envs: N.
            shares: the observations (shares, columns, size), info (rows, shares, columns), flags (3, shares,
                columns) and codes (shares, columns): :class:`~rolling_disk_env.engine.OutputArrays`.
        """
        self.num_envs, self.shares = num_envs, shares
        observations, info, flags, codes = shares
        width = info.shape[1] * info.shape[2]
        self.blocks = (
            observations.reshape(width, -1),
            info.reshape(-1, width),
            flags.reshape(3, width),
            codes.reshape(width),
        )
        self.observations = self.blocks[0][:num_envs]
        self.info, self.flags = self.blocks[1][:, :num_envs], self.blocks[2][:, :num_envs]
        self.codes = self.blocks[3][:num_envs]

    def __reduce__(self):
        """Pickles the arrays, not their views (which pickle as copies)."""
        return Outputs, (self.num_envs, self.shares)

    @classmethod
    def empty(
        cls,
        num_envs: int,
        observation_size: int,
        rows: int,
        zeroed: bool = True,
        shares: tuple[int, int] = (1, 0),
    ) -> Outputs:
        """New arrays, an info block of ``rows`` rows, for ``shares`` = (count, columns of each; 0: N): zeros, or
        (``zeroed=False``, for a step, which writes every disk's) uninitialized."""
        make, (count, share) = (np.zeros if zeroed else np.empty), shares
        share = share or num_envs
        return cls(
            num_envs,
            (
                make((count, share, observation_size), dtype=np.float32),
                make((rows, count, share)),
                make((3, count, share), dtype=bool),
                make((count, share), dtype=np.int64),
            ),
        )


class DiskBatch:
    """The state of N disks (in the engine's lanes array, with their goals and step counts) and the compiled step and
    reset of their task.

    Args:
        config: the env's checked settings.
        num_envs: N.
        max_episode_steps: steps before the engine truncates an episode (None: never; the single env leaves it to
            Gymnasium's TimeLimit wrapper).
    """

    def __init__(self, config: EnvConfig, num_envs: int, max_episode_steps: int | None, info_keys: str = "full"):
        task = config.task
        steps = task_steps(task)
        self.num_envs = num_envs
        self.info_keys = info_keys
        """What the step writes beside the observations, rewards and flags: ``"full"`` (every row of the info block)
        or ``"training"`` (the termination codes; ``rolling_disk_env.codegen.INFO_SETS``)."""
        self.threads, self.share = self._layout(num_envs)
        width = self.threads * self.share
        # The kernel that steps and resets a range of shares: one compiled function for the single env's and the vector
        # env's steps and resets, for one integrator and one contact family, on the calling thread or on threads.
        self.method = config.integrator if config.contact == "rolling" else "contact"
        """The step's method: the integrator under the ``"rolling"`` contact, else ``"contact"``."""
        self._shares = (
            getattr(steps, f"step_{self.method}{set_suffix(info_keys)}_share"),
            steps.reset_share if config.contact == "rolling" else steps.reset_contact_share,
        )
        """The share functions of the configuration's step and reset (``_generated/<task>.py``)."""
        self.description = (
            f"the step and reset of task {task.name!r} ({self.method}, {config.contact} contact, {info_keys} outputs)"
        )
        """What the kernels compute, as the compile log names them (:func:`entry_point`)."""
        self.contact_rows = None if config.contact == "rolling" else steps.CONTACT_ROWS
        """The first row of ``engine.SLIDING_INFO`` in the info block (None under the ``"rolling"`` contact)."""
        first = self.contact_rows
        self.state_rows = slice(0, 8) if first is None else np.array([0, 1, 2, 3, 4, first, first + 1, 5, 6, 7])
        """The rows of the disks' state in the info block: the 8-state, or the 10-state under the ``"sliding"`` and
        ``"coulomb"`` contacts (the centre's velocity among the rows of ``engine.SLIDING_INFO``)."""
        self.choice = ThreadChoice() if self.threads > 1 else None
        """How a batch of several shares steps them (None: one share, on the calling thread)."""
        if num_envs >= HEAP_FROM:
            keep_freed_memory()
        self.drawn_rows = [(name, engine.MASS + DRAWN.index(name)) for name in config.drawn_names]
        """The info keys of the disk's constants drawn per episode (``params_ranges``) and their lanes rows."""
        self.terms = len(task.reward_weights)
        self.observation_size = len(task.observation_names)
        # Per disk.
        self.lanes = np.zeros((engine.LANES, width))
        self.lanes[engine.MASS : engine.MU + 1] = config.disk_ranges[:, :1]  # the padding's too
        self.lanes[engine.STEP_SIZE] = config.dt  # the padding's too: a dopri5 step of 0 s would never end
        self.lanes[[engine.ANGLES + 1, engine.ANGLES + 3]] = 1.0  # kernels.angles of the zero state: the padding's
        self.goals = np.zeros((task.goal_size, width))
        self.steps = np.zeros(width, dtype=np.int64)
        self.uniforms = np.zeros((num_envs, config.draws))
        self.no_state = np.full((num_envs, GIVEN_SIZE), np.nan)
        """The initial states a reset takes (``engine.ResetArrays.given``): rows of NaN, but during a reset to given
        states."""
        self.mask = np.zeros(num_envs, dtype=bool)
        """The disks the next compiled call resets (``engine.ResetArrays.mask``): none between calls."""
        self._no_actions = np.zeros((0, config.action_space.shape[0]), dtype=np.float32)
        self.observation_rows = slice(engine.TERMS + self.terms, engine.TERMS + self.terms + self.observation_size)
        """The rows of the observation (clipped, float64) in an info block."""
        self.rows = self.observation_rows.stop + (0 if self.contact_rows is None else 5)
        """Rows of an info block."""
        self.setup = tuple(
            engine.SetupArrays(
                config=config.engine_config(max_episode_steps),
                actuators=config.actuators_array,
                settings=task.settings,
                weights=task.weights,
                bounds=task.observation_high,
                disk_ranges=config.disk_ranges,
                ranges=config.ranges,
            )
        )
        """The settings, as the kernels take them (:class:`~rolling_disk_env.engine.SetupArrays`, a plain tuple)."""
        self._no_rngs = np.zeros((0, 4), dtype=np.uint64)
        self._rngs = self._no_rngs  # the PCG64 states in the bundle's resets
        self._functions = None  # the compiled share functions (_share_functions)
        self._bundle()

    def _layout(self, num_envs: int) -> tuple[int, int]:
        """The shares of ``num_envs`` disks: how many (one per thread, :func:`thread_count`) and the columns of each
        (:func:`columns`)."""
        threads = thread_count(num_envs)
        return threads, columns(-(-num_envs // threads))

    @property
    def states(self) -> np.ndarray:
        """The disks' rolling states ``(c1, c2, phi, theta, psi, dphi, dtheta, dpsi)``, (8, N): a view of the lanes
        (under the ``"sliding"`` and ``"coulomb"`` contacts, the centre's velocity is in rows
        ``engine.CENTRE_VELOCITY``)."""
        return self.lanes[engine.STATE : engine.STATE + 8, : self.num_envs]

    @property
    def disks(self) -> np.ndarray:
        """The disks' constants (m, g, r), (3, N): a view of the lanes."""
        return self.lanes[engine.MASS : engine.RADIUS + 1, : self.num_envs]

    def outputs(self, zeroed: bool = True) -> Outputs:
        """New output arrays for the batch (see :meth:`Outputs.empty`)."""
        return Outputs.empty(self.num_envs, self.observation_size, self.rows, zeroed, (self.threads, self.share))

    def __getstate__(self) -> dict:
        """Pickles the arrays, not the views of them the step takes (which would pickle as copies), nor the compiled
        functions (addresses in this process)."""
        left_out = ("_arrays", "_entries", "_rngs", "_functions")
        return {key: value for key, value in self.__dict__.items() if key not in left_out}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._rngs = self._no_rngs
        self._functions = None
        self._bundle()

    def _bundle(self) -> None:
        """Forgets the batch's :class:`~rolling_disk_env.engine.Bundle`, which :meth:`_call` builds again: its
        :meth:`shares`, settings and resets, with the compiled share functions (:meth:`_share_functions`)."""
        self._entries = [None] * 2  # engine.step_range (_serial), and engine.step_shares (_threaded), compiled
        self._arrays = None

    def _share_functions(self, actions: np.ndarray, out: Outputs) -> tuple:
        """The configuration's step and reset share functions compiled for the types of the batch's arrays (or loaded
        from numba's cache), as first-class functions (:func:`~rolling_disk_env.jit.first_class`), once."""
        if self._functions is None:
            batch, setup = self.shares(), self.setup
            resets = (self.mask, self._rngs, self.uniforms, self.no_state)
            step, reset = self._shares
            k = np.int64(0)
            calls = [(step, (k, actions, batch, setup, out.shares)), (reset, (k, resets, batch, setup, out.shares))]
            compiled(calls, self.description)
            self._functions = tuple(first_class(kernel, args) for kernel, args in calls)
        return self._functions

    def _draw_from(self, rngs: np.ndarray | None) -> None:
        """Puts ``rngs`` (or none: the uniforms as they are) into the bundle's resets, if they are not there (a vector
        env passes the same array every time: the bundle is built again once)."""
        rngs = self._no_rngs if rngs is None else rngs
        if rngs is not self._rngs:
            self._rngs = rngs
            self._bundle()

    def shares(self) -> tuple:
        """The lanes, goals and step counts (:class:`~rolling_disk_env.engine.BatchArrays`, a plain tuple), split into
        the shares (views): ``[row, k, i]`` for disk i of share k."""
        split = (self.threads, self.share)
        return self.lanes.reshape(-1, *split), self.goals.reshape(-1, *split), self.steps.reshape(split)

    def reset(
        self, mask: np.ndarray, out: Outputs, rngs: np.ndarray | None = None, states: np.ndarray | None = None
    ) -> None:
        """Starts new episodes in the disks of ``mask``, writing their outputs into ``out``.

        Args:
            mask: (N,), bool.
            out: where the disks' first observation and info go.
            rngs: (N, 4) uint64 PCG64 states to draw the episodes from (:mod:`rolling_disk_env.pcg64`); None to use
                the uniforms already in :attr:`uniforms`.
            states: (N, 8) initial states that replace the drawn ones (rows of NaN: none), or None; (N, 10) under
                the ``"sliding"`` and ``"coulomb"`` contacts (centre velocities of NaN: from the rolling constraint).
        """
        self._draw_from(rngs)
        np.copyto(self.mask, mask)
        if states is not None:
            self.no_state[:] = given_states(states)
        try:
            self._call(False, self._no_actions, out)
        finally:
            self.mask.fill(False)
            if states is not None:
                self.no_state.fill(np.nan)

    def step(
        self, actions: np.ndarray, out: Outputs, resetting: np.ndarray | None = None, rngs: np.ndarray | None = None
    ) -> int:
        """Steps every disk under normalized ``actions`` (N, A: C-contiguous float32), writing the outputs into
        ``out``; then, in the same compiled call, starts new episodes in the disks of ``resetting`` (their actions
        are ignored and their outputs are their first ones), drawn from ``rngs`` as :meth:`reset` draws them.

        Args:
            actions: (N, A), C-contiguous float32.
            out: where the outputs go.
            resetting: (N,) C-contiguous bool, or None for no reset.
            rngs: (N, 4) uint64 PCG64 states, with ``resetting``.

        Returns:
            The first disk whose action is not finite (then nothing was stepped or reset), or -1.
        """
        if resetting is None:
            return self._call(True, actions, out)
        self._draw_from(rngs)
        np.copyto(self.mask, resetting)
        try:
            return self._call(True, actions, out)
        finally:
            self.mask.fill(False)

    def _call(self, stepping: bool, actions: np.ndarray, out: Outputs) -> int:
        """Calls the compiled step (``stepping``: a step, then the resets of :attr:`mask`) or reset (the resets
        alone), on the shares one after the other or on numba's threads, a share each, as :attr:`choice` says (which
        times the steps)."""
        if self._arrays is None:
            resets = (self.mask, self._rngs, self.uniforms, self.no_state)
            self._arrays = engine.bundle(self.shares(), self.setup, resets, *self._share_functions(actions, out))
        arguments = (actions, self._arrays, out.shares, stepping, (0, self.threads))
        if self.choice is None:
            return self._serial(arguments)(*arguments)
        threaded = self.choice.next() if stepping else self.choice.threaded
        start = time.perf_counter()
        if threaded:
            bad = self._threaded(arguments)(*arguments[:-1])
        else:
            bad = self._serial(arguments)(*arguments)
        if stepping:
            self.choice.record(threaded, time.perf_counter() - start)
        return bad

    def _serial(self, arguments: tuple):
        """:func:`~rolling_disk_env.engine.step_range` compiled (:func:`entry_point`: once for every configuration),
        for ``arguments`` of the types every call passes: ``actions`` a C-contiguous float32 (N, A) array (a reset
        passes one of no rows), the batch's bundle, outputs of :meth:`outputs`, whether to step, and the range of
        shares (two ints)."""
        if self._entries[0] is None:
            self._entries[0] = entry_point(engine.step_range, arguments, "the call of a batch's shares")
        return self._entries[0]

    def _threaded(self, arguments: tuple):
        """:func:`~rolling_disk_env.engine.step_shares` compiled (:func:`entry_point`: once for every configuration),
        for ``arguments`` less the range of shares."""
        if self._entries[1] is None:
            self._entries[1] = entry_point(
                engine.step_shares, arguments[:-1], "the call of a batch's shares on threads"
            )
        return self._entries[1]
