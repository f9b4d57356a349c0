"""The GPU target: the engine's generated steps as CUDA kernels (numba-cuda), a thread a disk, on device memory.

One source, two targets. A batch of N disks on the GPU is a batch of N *shares* of one disk each: its arrays are the
CPU engine's, shaped ``[row, k, 0]`` for disk k (:class:`DeviceBatch`: a
:class:`~rolling_disk_env.envs.batch.DiskBatch` of N shares), and thread k of a kernel calls the task's generated
``step_<method>_share(k, ...)`` or ``reset_share(k, ...)``: the functions the CPU's loops call, with their model,
integrators, contact switching and task formulas, which numba-cuda compiles again as device functions. The kernels
themselves are one call each, written by :mod:`rolling_disk_env.codegen` into ``_generated/cuda.py``. Consecutive
threads touch consecutive addresses of each row, so the loads and stores of a warp coalesce.

What differs from the CPU lives here: device memory, the launches (on torch's current stream), and the kernels'
cache. Another compiler (numba-cuda's successor, NVIDIA Warp) would replace this module and ``_generated/cuda.py``.

Without a GPU, numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``) runs the kernels on the CPU, a Python thread a
GPU thread: device memory is then host memory (numpy arrays, torch CPU tensors) and each thread calls the
CPU-compiled share function, so that the whole GPU path is testable without one.

Arithmetic: NVVM fuses ``a * b + c`` into one rounding (numba-cuda has no switch to turn that off), so results differ
from the CPU's in the last bits (within 1e-12 relative over 200 steps); ``math.sqrt``, division and the package's
``trig.sincos`` are IEEE on both. Under the simulator they are the CPU's, to the last bit.
"""

from __future__ import annotations

import collections
import functools
import importlib.util
import logging
import math
import time
import warnings

import numba
import numpy as np
import torch

from rolling_disk_env import engine, pcg64
from rolling_disk_env.constants import set_suffix
from rolling_disk_env.envs.batch import GIVEN_SIZE, DiskBatch, Outputs, given_states
from rolling_disk_env.envs.config import EnvConfig
from rolling_disk_env.jit import _PackageStamp

if importlib.util.find_spec("numba_cuda") is None:  # numba's own numba.cuda is its old, deprecated target
    raise ImportError(
        'device="cuda" needs numba-cuda, which is not installed: pip install "rolling-disk-env[gpu]" (numba-cuda '
        "with its CUDA 13 wheels, and rsl-rl-lib)"
    )
from numba import cuda  # numba-cuda's (checked above)
from numba.cuda.core import caching as cuda_caching

log = logging.getLogger(__name__)
SIMULATED = bool(numba.config.ENABLE_CUDASIM)
"""Whether numba-cuda's simulator runs the kernels (``NUMBA_ENABLE_CUDASIM=1``): on the CPU, with host memory."""
THREADS_PER_BLOCK = 128
"""Threads of a block at most: a disk each."""
WARP = 32
"""Threads of a warp: the fewest a block has (but for a batch of fewer disks)."""
FULL_GRID = 128
"""Blocks that numba-cuda takes as enough to use a GPU (fewer: its ``NumbaPerformanceWarning``, "Grid size ... will
likely result in GPU under-utilization")."""


class _UserProvidedLocator(_PackageStamp, cuda_caching._UserProvidedCacheLocator):
    """In ``NUMBA_CACHE_DIR``, stamped with the package's sources (:func:`rolling_disk_env.jit.package_stamp`)."""


class _InTreeLocator(_PackageStamp, cuda_caching._InTreeCacheLocator):
    """In ``__pycache__`` beside ``_generated/cuda.py``, stamped likewise."""


class _UserWideLocator(_PackageStamp, cuda_caching._UserWideCacheLocator):
    """In numba's user-wide cache directory, stamped likewise."""


def _use_package_stamps() -> None:
    """numba-cuda judges a cached kernel by its own file's source; the kernels hold the code of the whole engine."""
    locators = cuda_caching.CacheImpl._locator_classes
    ours = (_UserProvidedLocator, _InTreeLocator, _UserWideLocator)
    locators[:] = [*ours, *(locator for locator in locators if locator not in ours)]


_use_package_stamps()


def require_device() -> None:
    """Raises ``RuntimeError`` naming what is missing where no CUDA GPU can run the kernels."""
    if SIMULATED or (cuda.is_available() and torch.cuda.is_available()):
        return
    if cuda.is_available():
        raise RuntimeError(
            f'device="cuda": numba-cuda sees a GPU but torch {torch.__version__} was built without CUDA; install '
            "PyPI's torch==2.13.0 (the CUDA build) for the torch tensors on the GPU"
        )
    raise RuntimeError(
        'device="cuda" found no CUDA GPU: numba-cuda is installed but sees no NVIDIA driver or device '
        "(numba.cuda.is_available() is False; `nvidia-smi` should list the GPU). Without one, "
        'device="cpu" gives the same torch interface over the CPU engine, and NUMBA_ENABLE_CUDASIM=1 runs the '
        "CUDA kernels in numba-cuda's simulator (slow: for tests)"
    )


def torch_device() -> torch.device:
    """The torch device of the kernels' memory: the current CUDA device, or the CPU under the simulator."""
    return torch.device("cpu") if SIMULATED else torch.device("cuda", torch.cuda.current_device())


def view(tensor: torch.Tensor):
    """The kernels' view of a torch tensor on :func:`torch_device` (no copy): a numba device array, or under the
    simulator the numpy array of the CPU tensor."""
    return tensor.numpy() if SIMULATED else cuda.as_cuda_array(tensor.detach())


def _stream():
    """torch's current CUDA stream, as numba-cuda's: the kernels and the copies run on it, in order."""
    return _external_stream(torch.cuda.current_stream().cuda_stream)


@functools.lru_cache(maxsize=16)
def _external_stream(handle: int):
    """numba-cuda's view of the CUDA stream ``handle`` (made once: a step asks for it every time)."""
    return cuda.external_stream(handle)


@functools.lru_cache(maxsize=16)
def _driver_stream(handle: int):
    """``cuda.core``'s view of the CUDA stream ``handle``, for :class:`Launch` (made once)."""
    from cuda.core import Stream

    return Stream.from_handle(handle)


def to_device(array: np.ndarray):
    """A host array copied to device memory, on torch's current stream (the array itself under the simulator)."""
    return array if SIMULATED else cuda.to_device(np.ascontiguousarray(array), stream=_stream())


def to_host(array) -> np.ndarray:
    """A device array copied to host memory once the work queued on torch's current stream is done (the array itself
    under the simulator)."""
    if SIMULATED:
        return array
    stream = _stream()
    host = array.copy_to_host(stream=stream)
    stream.synchronize()
    return host


@functools.cache
def kernel(task: str, name: str):
    """The compiled kernel ``<task>_<name>`` of ``_generated/cuda.py`` (``step_<method>``, ``reset`` or
    ``reset_contact``), cached on
    disk (under the simulator, run in Python). numba-cuda compiles it at its first launch."""
    from rolling_disk_env._generated import cuda as kernels

    return _jit(getattr(kernels, f"{task}_{name}"))


def _jit(function):
    """``function`` as a CUDA kernel, cached on disk (under the simulator, run in Python)."""
    return cuda.jit(function) if SIMULATED else cuda.jit(function, cache=True)


def _blocks(disks: int) -> tuple[int, int]:
    """Blocks and threads of a launch over ``disks`` threads: blocks of :data:`THREADS_PER_BLOCK`, smaller (down to a
    warp) where that many would make fewer than :data:`FULL_GRID` blocks, so that a batch of 4,096 disks (``train.py
    --device cuda``'s) runs in 128 blocks of 32 instead of 32 of 128, spread over more of the GPU's multiprocessors."""
    threads = min(disks, max(WARP, min(THREADS_PER_BLOCK, WARP * (disks // (FULL_GRID * WARP)))))
    return math.ceil(disks / threads), threads


def launch(function, disks: int, *arguments) -> None:
    """Runs a kernel on ``disks`` threads with ``arguments`` (device arrays, numbers and tuples of them), on torch's
    current CUDA stream: numba-cuda's own launch, which types and converts the arguments every time (about 250 us for
    a step kernel's). The env's kernels launch through :class:`Launch` instead."""
    _numba_launch(function, *_blocks(disks), arguments)


def _numba_launch(function, blocks: int, threads: int, arguments: tuple) -> None:
    """numba-cuda's launch of ``function`` on torch's current stream. A batch of fewer than 4,096 disks cannot fill
    :data:`FULL_GRID` blocks of a warp: numba-cuda's warning that says so is filtered here, where it is raised (the
    batch's size is the user's choice, and a small one is meant for few disks, not for a full GPU)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Grid size \d+ will likely result in GPU under-utilization")
        if SIMULATED:
            function[blocks, threads](*arguments)
        else:
            function[blocks, threads, _stream()](*arguments)


class Launch:
    """The launches of a kernel over ``disks`` threads, always with the same ``arguments`` (device arrays, numbers and
    tuples of them: the kernel reads and writes the arrays' memory, which the caller fills in place), resolved once.

    numba-cuda's launch types the arguments, converts them to the kernel's parameters and looks up the compiled kernel
    at every call (about 250 us for a step kernel's nested tuple of 21 arrays). Here the first call compiles the
    kernel (or loads it from the cache) and converts the parameters once, with numba-cuda's own conversion; each call
    then hands the same parameters to the driver (``cuda.core.launch``) on torch's current stream. Where that cannot be
    done (another numba-cuda's internals), the launches are numba-cuda's own, logged once. Under the simulator a call
    is numba-cuda's own.

    Attributes:
        compiled: numba-cuda's compiled kernel, once launched on a GPU (its ``regs_per_thread`` and
            ``local_mem_per_thread``); None before, and under the simulator.
    """

    def __init__(self, function, disks: int, arguments: tuple):
        self.function, self.arguments = function, arguments
        self.blocks, self.threads = _blocks(disks)
        self.compiled = None
        self._resolved = SIMULATED or None  # True: numba-cuda's own launches; else (launch, config, kernel, parameters)

    def __call__(self) -> None:
        if self._resolved is None:
            self._resolved = self._resolve()
        elif self._resolved is True:
            _numba_launch(self.function, self.blocks, self.threads, self.arguments)
        else:
            driver_launch, config, kernel, parameters = self._resolved
            driver_launch(_driver_stream(torch.cuda.current_stream().cuda_stream), config, kernel, *parameters)

    def _resolve(self):
        """Launches the kernel compiled for the arguments' types (or loaded from the cache) with its parameters,
        converted once, and returns those; or, where only numba-cuda's own launch can run it, launches that and
        returns True."""
        types = tuple(self.function.typeof_pyval(value) for value in self.arguments)
        start = time.perf_counter()
        self.compiled = self.function.compile(types)
        seconds = time.perf_counter() - start
        if seconds > 1.0:  # compiled, not loaded from the cache
            name = getattr(self.function, "__name__", "kernel")
            device = cuda.get_current_device().name
            device = device.decode() if isinstance(device, bytes) else device
            log.info("compiled the CUDA kernel %s for %s in %.1f s (cached for later runs)", name, device, seconds)
        try:
            from cuda.core import LaunchConfig
            from cuda.core import launch as driver_launch

            parameters, kept = [], []
            for kind, value in zip(self.compiled.argument_types, self.arguments):
                self.compiled._prepare_args(kind, value, 0, kept, parameters)
            kernel = self.compiled._codelibrary.get_cufunc().kernel
            resolved = (driver_launch, LaunchConfig(grid=self.blocks, block=self.threads), kernel, tuple(parameters))
            driver_launch(_driver_stream(torch.cuda.current_stream().cuda_stream), resolved[1], kernel, *resolved[3])
        except (ImportError, AttributeError, TypeError) as error:  # before the launch: nothing ran
            log.warning("numba-cuda's own launches for %s (parameters not resolved once: %s)", types, error)
            _numba_launch(self.function, self.blocks, self.threads, self.arguments)
            return True
        return resolved


def _check(actions, ended, disabled, status, queue):
    """Disk k's part of the check before a step (:attr:`DeviceBatch.status`): ``status[0]`` becomes the first disk
    whose action (a row of ``actions``) is not finite and ``status[2]`` counts those disks, and where ``disabled``
    (DISABLED autoreset) ``status[1]`` becomes the first disk that has ended; they hold N, N and 0 until a step finds
    one (then they stay, and no later step steps a disk, until the host reads them:
    :meth:`DeviceBatch.raise_pending`). Thread 0 empties the hybrid's ``queue`` (its count,
    :class:`~rolling_disk_env.engine.DeviceControl`) for the step that follows."""
    k = cuda.grid(1)
    if k == 0:
        queue[0] = 0
    if k < actions.shape[0]:
        finite = True
        for j in range(actions.shape[1]):
            finite = finite and math.isfinite(actions[k, j])
        if not finite:
            cuda.atomic.min(status, 0, k)
            cuda.atomic.add(status, 2, 1)
        if disabled and ended[k]:
            cuda.atomic.min(status, 1, k)


def _seed(arguments):
    """Disk k's PCG64 state, where ``mask`` holds it: numpy's ``PCG64(SeedSequence(seed + k))``
    (:func:`rolling_disk_env.pcg64.seed_state`), ``arguments`` being the seed's high and low 64 bits, the mask and the
    states (one tuple, as the generated kernels take theirs: the simulator hands its arrays to the CPU's function)."""
    seed_high, seed_low, mask, rngs = arguments
    k = cuda.grid(1)
    if k < rngs.shape[0] and mask[k]:
        pcg64.seed_state(seed_high, seed_low, np.uint64(k), rngs[k])


def wait_for(event) -> None:
    """Waits for the device to pass ``event``: the one place where a :class:`DeviceBatch` waits for the device, which
    its :meth:`~DeviceBatch.step` does only when :data:`PENDING_STEPS` steps are unread (a reset waits for them all)."""
    event.synchronize()


PENDING_STEPS = 64
"""Steps whose status word the host may leave unread: past it, a step waits for the oldest (the host would otherwise
run that far ahead of the device)."""


class DeviceStepError(ValueError):
    """A step of a :class:`DeviceBatch` found a non-finite action, or under DISABLED an ended disk: it stepped no disk,
    nor did the steps after it until this was raised (:meth:`DeviceBatch.raise_pending`); their outputs are
    meaningless.

    Attributes:
        step: the step's number (:attr:`DeviceBatch.steps_taken` after it).
        first: the first disk with a non-finite action (N: none).
        count: the disks with a non-finite action.
        ended: the first disk that had ended, under DISABLED (N: none).
    """

    def __init__(self, step: int, first: int, count: int, ended: int, batch: DeviceBatch):
        self.step, self.first, self.count, self.ended = step, first, count, ended
        n = batch.num_envs
        if first < n:
            message = (
                f"actions must be finite numbers: step {step} got a non-finite action for {count} sub-environment(s), "
                f"the first {first}; no sub-environment has been stepped since (the outputs of the steps after it are "
                "meaningless)"
            )
        else:
            disks = torch.nonzero(batch.ended).flatten().tolist()
            message = (
                f"sub-environments {disks} have ended and autoreset is disabled: reset them with "
                f'reset(options={{"reset_mask": mask}}) first (step {step} stepped none, nor have the steps since)'
            )
        super().__init__(message)


class DeviceBatch(DiskBatch):
    """A :class:`~rolling_disk_env.envs.batch.DiskBatch` on the GPU: N shares of one disk, in device memory, stepped
    and reset by its task's CUDA kernels, a thread a disk, with the autoreset decided on the device.

    A step is a copy of the actions into the batch's buffer, two launches (the check of the actions, then the step,
    which writes every output the env hands out, the same-step resets included), one copy of the outputs that must
    be fresh, and an asynchronous copy of the check's status word into pinned host memory, which a later
    :meth:`step` reads once the device has done it: the host never waits for the device (:meth:`step`,
    :meth:`raise_pending`). Under the ``"sliding"`` and ``"coulomb"`` contacts
    the step is two kernels: every disk's rolling pass, which queues the disks that need the hybrid, then the hybrid
    pass of the queued disks only, a thread each, so that a disk that slides holds up no warp of rolling disks. Its
    buffers are made once, and the kernels' parameters resolved once (:class:`Launch`): nothing else crosses between
    host and device.

    Args:
        config: the env's checked settings.
        num_envs: N.
        max_episode_steps: steps before the kernels truncate an episode (None: never).
        mode: the autoreset mode (``engine.NEXT_STEP``, ``engine.SAME_STEP`` or ``engine.DISABLED``).

    Attributes (torch tensors on :attr:`device`, written in place by the kernels):
        out: the outputs of the latest step or reset (:class:`~rolling_disk_env.envs.batch.Outputs`; the
            observations a view of the block that :meth:`step` copies).
        rewards: (N,) float32, the latest step's rewards, and dones: (2, N) bool, its terminated and truncated
            flags: views of the same block.
        final: SAME_STEP's last outputs of the disks that ended at the latest step (the rows of :attr:`final_mask`).
        final_mask: (N,) bool.
        final_disk: (DISK_CONSTANTS, N) float64, their constants (m, g, r, mu) there.
        ended: (N,) bool, the disks whose episode ended at their latest step (NEXT_STEP and DISABLED).
        steps_tensor: (N,) int64, each disk's steps in its episode (it truncates at ``max_episode_steps``);
            writable.
        status: (3,) int64, the check's word (:class:`~rolling_disk_env.engine.DeviceControl`; :func:`_check`).
        steps_taken: :meth:`step` calls since the batch was made (the number an error names its step by).
        queue: (N + 1,) int64, the disks of the latest step's hybrid pass, after their count
            (:class:`~rolling_disk_env.engine.DeviceControl`; ``"sliding"`` and ``"coulomb"`` contacts).
    Not picklable.
    """

    def __init__(
        self,
        config: EnvConfig,
        num_envs: int,
        max_episode_steps: int | None,
        mode: int = engine.NEXT_STEP,
        info_keys: str = "training",
    ):
        require_device()
        super().__init__(config, num_envs, max_episode_steps, info_keys)
        self.choice = None
        self.device = torch_device()
        n, size = num_envs, self.observation_size
        rolling, task, suffix = config.contact == "rolling", config.task.steps_name, set_suffix(info_keys)
        step = kernel(task, f"step_{config.integrator}{suffix}" if rolling else f"step_contact{suffix}")
        hybrid = None if rolling else kernel(task, f"step_contact_hybrid{suffix}")
        self._kernels = (step, kernel(task, "reset" if rolling else "reset_contact"), _jit(_check), hybrid)
        self.mode = mode
        # What a step hands out fresh, in one float32 block (one copy): the observations and rewards, then terminated
        # and truncated as bytes.
        self._fresh = torch.zeros(n * size + n + (2 * n + 3) // 4, dtype=torch.float32, device=self.device)
        observations, self.rewards, terminated, _ = self._fresh_views(self._fresh)
        self.dones = terminated.as_strided((2, n), (n, 1))  # terminated's bytes, then truncated's
        host = super().outputs()
        on_device = tuple(torch.from_numpy(array).to(self.device) for array in host.shares[1:])
        self.out = Outputs(n, (observations.view(n, 1, size), *on_device))
        self.final = Outputs(n, tuple(torch.zeros_like(array) for array in self.out.shares))
        self.final_mask = torch.zeros(n, dtype=torch.bool, device=self.device)
        self.final_disk = torch.zeros((engine.DISK_CONSTANTS, n), dtype=torch.float64, device=self.device)
        self.ended = torch.zeros(n, dtype=torch.bool, device=self.device)
        self.status = torch.tensor([n, n, 0], dtype=torch.int64, device=self.device)
        self.queue = torch.zeros(n + 1, dtype=torch.int64, device=self.device)
        self.actions = torch.zeros((n, config.action_space.shape[0]), dtype=torch.float32, device=self.device)
        self.mask = torch.zeros(n, dtype=torch.bool, device=self.device)
        self.given = torch.full((n, GIVEN_SIZE), math.nan, dtype=torch.float64, device=self.device)
        self._given = False  # whether given holds states (else NaN)
        self.rngs = to_device(np.zeros((n, 4), dtype=np.uint64))
        """The disks' PCG64 states (:mod:`rolling_disk_env.pcg64`) in device memory, advanced by the resets."""
        self._uniforms = to_device(self.uniforms)
        self.steps_taken = 0
        # The status words of the steps the host has not read yet: (step number, host buffer, event), oldest first,
        # in a ring of pinned buffers.
        self._pending: collections.deque = collections.deque()
        self._words = [torch.empty(3, dtype=torch.int64, pin_memory=not SIMULATED) for _ in range(PENDING_STEPS)]
        self._word_arrays = [word.numpy() for word in self._words]  # read on the host without a torch call

    def _fresh_views(self, block: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """The observations (N, size) float32, rewards (N,) float32, terminated and truncated (N,) bool of a block of
        :attr:`_fresh`'s layout, in five tensor operations (each costs the host about a microsecond a step)."""
        n, size = self.num_envs, self.observation_size
        flags = block.view(torch.bool)
        return (
            block.as_strided((n, size), (size, 1)),
            block.as_strided((n,), (1,), n * size),
            flags.as_strided((n,), (1,), 4 * (n * size + n)),
            flags.as_strided((n,), (1,), 4 * (n * size + n) + n),
        )

    def _layout(self, num_envs: int) -> tuple[int, int]:
        """A share a disk: thread k of a kernel steps share k."""
        return num_envs, 1

    def _bundle(self) -> None:
        """The batch's arrays and settings in device memory (copied from the host's); the launches are resolved again
        at the next step or reset."""
        self._device = (
            tuple(to_device(array) for array in self.shares()),
            tuple(to_device(array) for array in self.setup),
        )
        self._launches = None

    @functools.cached_property
    def steps_tensor(self) -> torch.Tensor:
        """(N,) int64: each disk's steps in its current episode, a view of device memory (the kernels truncate an
        episode when it reaches ``max_episode_steps``; writing it moves the disks within their episodes)."""
        steps = self._device[0][2]
        return (torch.from_numpy(steps) if SIMULATED else torch.as_tensor(steps, device=self.device)).view(-1)

    @functools.cached_property
    def disk_tensor(self) -> torch.Tensor:
        """(DISK_CONSTANTS, N) float64: each disk's constants (m, g, r, mu: the lanes rows MASS to MU) in its current
        episode, a view of device memory."""
        lanes = self._device[0][0]
        lanes = torch.from_numpy(lanes) if SIMULATED else torch.as_tensor(lanes, device=self.device)
        return lanes.view(engine.LANES, -1)[engine.MASS : engine.MU + 1]

    def _prepared(self) -> tuple[Launch, Launch, Launch, Launch | None]:
        """The launches of the step, the reset, the check and the step's hybrid pass (None under the ``"rolling"``
        contact), with the arguments of :class:`DeviceBatch`'s buffers."""
        if self._launches is None:
            n = self.num_envs
            out = tuple(view(array) for array in self.out.shares)
            final = tuple(view(array) for array in self.final.shares)
            resets = (view(self.mask), self.rngs, self._uniforms, view(self.given))
            control = (
                view(self.status), view(self.ended), view(self.rewards), view(self.dones), final,
                view(self.final_mask), view(self.final_disk), self.mode, view(self.queue),
            )  # fmt: skip
            step, reset, check, hybrid = self._kernels
            actions, disabled = view(self.actions), self.mode == engine.DISABLED
            arguments = ((actions, *self._device, out, resets, control),)
            self._launches = (
                Launch(step, n, arguments),
                Launch(reset, n, ((resets, *self._device, out),)),
                Launch(check, n, (actions, view(self.ended), disabled, view(self.status), view(self.queue))),
                None if hybrid is None else Launch(hybrid, n, arguments),
            )
        return self._launches

    @property
    def step_arguments(self) -> tuple:
        """The step kernel's argument, ``(actions, batch, setup, out, resets, control)``: the views of the batch's
        buffers (:class:`~rolling_disk_env.engine.DeviceControl` for ``control``)."""
        return self._prepared()[0].arguments[0]

    def _to_host(self) -> None:
        """Copies the batch's arrays from device memory into the host's (no copy under the simulator)."""
        if SIMULATED:
            return
        lanes, goals, steps = (to_host(array) for array in self._device[0])
        self.lanes[:], self.goals[:], self.steps[:] = (
            lanes.reshape(self.lanes.shape),
            goals.reshape(self.goals.shape),
            steps.reshape(-1),
        )

    def load(self, batch: DiskBatch) -> None:
        """Sets the disks' lanes, goals and step counts to those of the CPU ``batch`` of the same configuration and N,
        so that both step from the same states (teacher-forced comparisons of the two targets)."""
        n = self.num_envs
        for device, host in zip(self._device[0][:3], (batch.lanes, batch.goals, batch.steps)):
            values = np.ascontiguousarray(host[..., :n]).reshape(device.shape)
            if SIMULATED:
                device[...] = values
            else:
                device.copy_to_device(values, stream=_stream())

    @property
    def states(self) -> np.ndarray:
        """The disks' rolling states, (8, N): a host copy."""
        self._to_host()
        return super().states

    def __getstate__(self):
        raise TypeError("a DeviceBatch lives in device memory: it cannot be pickled")

    def reset(self, mask: torch.Tensor | None, states: np.ndarray | None = None, seed: int | None = None) -> None:
        """Starts new episodes in the disks of ``mask`` ((N,) bool on the device; None: every disk), drawn from
        :attr:`rngs` (first seeded on the device where ``seed`` is given: disk k's state that of ``seed + k``, a
        non-negative int with ``seed + N`` below :data:`~rolling_disk_env.pcg64.SEED_LIMIT`), or from the host's
        ``states`` ((N, 8), or (N, 10) under the ``"sliding"`` and ``"coulomb"`` contacts; rows of NaN: drawn), writing
        into :attr:`out`; those disks have not ended. First raises the error of an earlier step (:meth:`raise_pending`,
        waiting for the device)."""
        self.raise_pending(wait=True)
        if mask is None:
            self.mask.fill_(True)
        else:
            self.mask.copy_(mask)
        if seed is not None:
            high, low = np.uint64(seed >> 64), np.uint64(seed & 0xFFFFFFFFFFFFFFFF)
            launch(_jit(_seed), self.num_envs, (high, low, view(self.mask), self.rngs))
        if states is not None:
            self.given.copy_(torch.from_numpy(given_states(states)))
        elif self._given:
            self.given.fill_(math.nan)
        self._given = states is not None
        self._prepared()[1]()
        self.ended.logical_and_(self.mask.logical_not())

    def step(self, actions: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Steps every disk under ``actions`` ((N, A) on the device; clipped to [-1, 1] by the kernel), with the
        autoreset of :attr:`mode`, unless an action of this step or of an earlier one was not finite or, under
        DISABLED, a disk had ended: then nothing is stepped, and :meth:`raise_pending` raises at the first call after
        the device has done that step (the next :meth:`step`, or :meth:`reset`). Nothing here waits for the device:
        first the status words of earlier steps that the device has copied are read (:meth:`raise_pending`), then
        this step's launches and the copy of its status word are queued.

        Returns:
            The fresh copies of the observations (N, size) and rewards (N,) float32 and of the flags terminated and
            truncated (N,) bool (meaningless from a step that stepped nothing on).
        """
        self.raise_pending()
        step, _, check, hybrid = self._prepared()
        self.actions.copy_(actions)
        check()
        step()
        if hybrid is not None:
            hybrid()
        fresh = self._fresh_views(self._fresh.clone())
        self.steps_taken += 1
        if len(self._pending) == PENDING_STEPS:  # the host is that many steps ahead of the device: wait for one
            self.raise_pending(oldest=True)
        slot = self.steps_taken % PENDING_STEPS
        self._words[slot].copy_(self.status, non_blocking=not SIMULATED)
        event = None if SIMULATED else torch.cuda.Event()
        if event is not None:
            event.record()
        self._pending.append((self.steps_taken, self._word_arrays[slot], event))
        return fresh

    def raise_pending(self, wait: bool = False, oldest: bool = False) -> None:
        """Reads the status words of the earlier steps the device has done (all of them with ``wait``, or the oldest
        with ``oldest``: waiting for the device; else those it has copied, without waiting), oldest first; raises
        :class:`DeviceStepError` for the first that found a non-finite action (or, under DISABLED, an ended disk),
        naming the step and the disks, and clears the status for the steps after the error is handled (no disk was
        stepped from that step on)."""
        while self._pending:
            number, word, event = self._pending[0]
            if event is not None:
                if wait or oldest:
                    wait_for(event)
                elif not event.query():
                    return
            self._pending.popleft()
            oldest = False
            bad, ended, count = int(word[0]), int(word[1]), int(word[2])
            if bad < self.num_envs or ended < self.num_envs:
                self._pending.clear()
                self.status.copy_(torch.tensor([self.num_envs, self.num_envs, 0]))
                raise DeviceStepError(number, bad, count, ended, self)

    def seed(self, words: np.ndarray, mask: np.ndarray) -> None:
        """Sets the PCG64 states of the disks of ``mask`` ((N,) bool) to those rows of ``words`` ((N, 4) uint64),
        through the host (a list of seeds; :meth:`reset` seeds ``seed + k`` on the device)."""
        host = to_host(self.rngs)
        np.copyto(host, words, where=mask[:, None])
        if not SIMULATED:
            self.rngs.copy_to_device(host, stream=_stream())
