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

import functools
import importlib.util
import math

import numba
import numpy as np
import torch

from rolling_disk_env.envs.batch import DiskBatch, Outputs, given_states
from rolling_disk_env.envs.config import EnvConfig
from rolling_disk_env.jit import _PackageStamp

if importlib.util.find_spec("numba_cuda") is None:  # numba's own numba.cuda is its old, deprecated target
    raise ImportError(
        'device="cuda" needs numba-cuda, which is not installed: pip install "rolling-disk-env[gpu]" (numba-cuda '
        "with its CUDA 13 wheels, and rsl-rl-lib)"
    )
from numba import cuda  # numba-cuda's (checked above)
from numba.cuda.core import caching as cuda_caching

SIMULATED = bool(numba.config.ENABLE_CUDASIM)
"""Whether numba-cuda's simulator runs the kernels (``NUMBA_ENABLE_CUDASIM=1``): on the CPU, with host memory."""
THREADS_PER_BLOCK = 128
"""Threads of a block: a disk each."""


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
    return cuda.external_stream(torch.cuda.current_stream().cuda_stream)


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
    """The compiled kernel ``<task>_<name>`` of ``_generated/cuda.py`` (``step_<method>`` or ``reset``), cached on
    disk (under the simulator, run in Python). numba-cuda compiles it at its first launch."""
    from rolling_disk_env._generated import cuda as kernels

    function = getattr(kernels, f"{task}_{name}")
    return cuda.jit(function) if SIMULATED else cuda.jit(function, cache=True)


def launch(function, disks: int, *arguments) -> None:
    """Runs a kernel on ``disks`` threads with ``arguments`` (device arrays, numbers and tuples of them: the generated
    kernels take one tuple), on torch's current CUDA stream."""
    threads = min(disks, THREADS_PER_BLOCK)
    blocks = math.ceil(disks / threads)
    if SIMULATED:
        function[blocks, threads](*arguments)
    else:
        function[blocks, threads, _stream()](*arguments)


class DeviceBatch(DiskBatch):
    """A :class:`~rolling_disk_env.envs.batch.DiskBatch` on the GPU: N shares of one disk, in device memory, stepped
    and reset by its task's CUDA kernels, a thread a disk.

    The same arguments and methods as the CPU batch, with torch tensors on :func:`torch_device` for the actions, the
    reset masks and the outputs: :meth:`outputs` returns the same tensors every time (the kernels write them in
    place; their views for the kernels are made once), and ``rngs`` are :attr:`rngs`. Not picklable.
    """

    def __init__(self, config: EnvConfig, num_envs: int, max_episode_steps: int | None):
        require_device()
        super().__init__(config, num_envs, max_episode_steps)
        self.choice = None
        self.device = torch_device()
        method = config.integrator if config.contact == "rolling" else "contact"
        self._step_kernel, self._reset_kernel = (
            kernel(config.task.name, f"step_{method}"),
            kernel(config.task.name, "reset"),
        )
        host = super().outputs()
        self._out = Outputs(num_envs, tuple(torch.from_numpy(array).to(self.device) for array in host.shares))
        self._out_views = tuple(view(tensor) for tensor in self._out.shares)
        self._actions = torch.zeros((num_envs, config.action_space.shape[0]), dtype=torch.float32, device=self.device)
        self._mask = torch.zeros(num_envs, dtype=torch.bool, device=self.device)
        self._views = (view(self._actions), view(self._mask))
        self.rngs = to_device(np.zeros((num_envs, 4), dtype=np.uint64))
        """The disks' PCG64 states (:mod:`rolling_disk_env.pcg64`) in device memory, advanced by the resets."""
        self._uniforms, self._no_state = to_device(self.uniforms), to_device(self.no_state)
        self._no_rngs = to_device(self._no_rngs)

    def _layout(self, num_envs: int) -> tuple[int, int]:
        """A share a disk: thread k of a kernel steps share k."""
        return num_envs, 1

    def _bundle(self) -> None:
        """The batch's arrays and settings in device memory (copied from the host's)."""
        self._device = (
            tuple(to_device(array) for array in self.shares()),
            tuple(to_device(array) for array in self.setup),
        )

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

    @property
    def states(self) -> np.ndarray:
        """The disks' rolling states, (8, N): a host copy."""
        self._to_host()
        return super().states

    def outputs(self, zeroed: bool = True) -> Outputs:
        """The batch's output tensors, written in place by every step and reset (``zeroed`` has no effect: a reset
        writes the disks it starts and leaves the others' latest outputs)."""
        return self._out

    def __getstate__(self):
        raise TypeError("a DeviceBatch lives in device memory: it cannot be pickled")

    def reset(self, mask, out: Outputs, rngs=None, states: np.ndarray | None = None) -> None:
        """Starts new episodes in the disks of ``mask`` (a bool array or tensor), drawn from ``rngs`` (:attr:`rngs`;
        None: the device's uniforms as the latest reset left them: the host's :attr:`uniforms` are not copied), or
        from the host's ``states``, writing into :meth:`outputs` (``out`` is that)."""
        self._mask.copy_(torch.as_tensor(mask))
        rngs = self._no_rngs if rngs is None else rngs
        given = self._no_state if states is None else to_device(given_states(states))
        resets = (self._views[1], rngs, self._uniforms, given)
        launch(self._reset_kernel, self.num_envs, (resets, *self._device, self._out_views))

    def step(self, actions: torch.Tensor, out: Outputs, resetting: torch.Tensor | None = None, rngs=None) -> int:
        """Steps every disk under ``actions`` (N, A) float32 on the device, then starts new episodes in the disks of
        ``resetting`` (a bool tensor, or None) from ``rngs`` (:attr:`rngs`), writing into ``out`` (:meth:`outputs`).
        Returns the first disk whose action is not finite (then nothing was stepped), or -1."""
        finite = torch.isfinite(actions).all(dim=1)
        if not bool(finite.all()):
            return int(torch.nonzero(~finite)[0, 0])
        self._actions.copy_(actions)
        if resetting is None:
            self._mask.zero_()
        else:
            self._mask.copy_(resetting)
        launch(self._step_kernel, self.num_envs, self.step_arguments(rngs))
        return -1

    def step_arguments(self, rngs=None) -> tuple:
        """The argument of the step kernels, ``(actions, batch, setup, out, resets)``: the batch's arrays and the views
        of its buffers of actions (N, A) and of the reset mask (N,), as the latest step or reset left them, with the
        PCG64 states ``rngs`` (:attr:`rngs`; None: the uniforms as they are)."""
        resets = (self._views[1], self._no_rngs if rngs is None else rngs, self._uniforms, self._no_state)
        return (self._views[0], *self._device, self._out_views, resets)

    def seed(self, rows: list[int], words: list[np.ndarray]) -> None:
        """Sets the PCG64 states of the disks ``rows`` to ``words`` (4 uint64 each)."""
        if not rows:
            return
        host = to_host(self.rngs)
        host[rows] = words
        if not SIMULATED:
            self.rngs.copy_to_device(host, stream=_stream())
