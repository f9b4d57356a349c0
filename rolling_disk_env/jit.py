"""How the package compiles: every compiled function is declared with :data:`kernel`, :data:`inline_kernel`,
:data:`share_kernel` or :data:`parallel_kernel`; a compiled kernel that another calls through its address is a
:func:`first_class` function.

Kernels are plain Python functions of floats and numpy arrays, compiled by numba on first call and cached on disk
(``cache=True``): in ``NUMBA_CACHE_DIR`` if it is set, else in ``__pycache__`` next to the module, or, where that is
not writable (a read-only site-packages), in numba's user-wide cache directory (``~/.cache/numba``). Where none of
them is writable (a read-only install used by a user without a writable home), the kernels compile in memory, again
in every process, after one line of warning (:data:`CACHE_DIRECTORY` is then None). ``NUMBA_DISABLE_JIT=1`` runs
every kernel as plain Python (slow: for debugging, and for the tests that compare compiled and interpreted results).

Numba judges a cached kernel fresh by the source of the file that defines it, but a kernel also holds the code of
the kernels it calls from other files (a task's step calls the generated model, the engine, the task module) and the
module constants it reads. So the package's kernels are cached under a stamp of *all* the package's source files
(:class:`PackageCacheLocator`): editing any of them recompiles, instead of running stale code.

A loop over a batch vectorizes only if LLVM can rule out, by checks run before the loop, that the arrays it writes
overlap those it reads (numba cannot tell LLVM that they never do). The fused step reads and writes a few dozen rows,
more pairs than LLVM checks by default (128): :func:`_allow_memory_checks` raises that limit, for this process's
compilations (the checks are comparisons of addresses, a few hundred nanoseconds a call; they change no result).

Arithmetic is IEEE: no ``fastmath``, so a compiled kernel gives the interpreted result to the last bit, and the same
kernel serves one disk and a batch. Division by zero gives inf or NaN as in numpy (``error_model="numpy"``) instead of
raising; the callers check states for finiteness.

Importing this module imports numba (about 0.3 s): the package imports it only when a kernel is first needed.
"""

from __future__ import annotations

import functools
import hashlib
import logging
from pathlib import Path

import llvmlite.binding
import numba
from numba.core import caching
from numba.core.types import WrapperAddressProtocol
from numba.experimental import function_type

PACKAGE = Path(__file__).resolve().parent


@functools.cache
def package_stamp() -> str:
    """A hash of every Python source file of the package (read once per process)."""
    digest = hashlib.sha256()
    for path in sorted(PACKAGE.rglob("*.py")):
        digest.update(str(path.relative_to(PACKAGE)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


class _PackageStamp:
    """A numba cache locator for the package's files only, stamped with :func:`package_stamp`."""

    def get_source_stamp(self):
        return package_stamp()

    @classmethod
    def from_function(cls, py_func, py_file):
        return super().from_function(py_func, py_file) if PACKAGE in Path(py_file).resolve().parents else None


class PackageUserProvidedCacheLocator(_PackageStamp, caching.UserProvidedCacheLocator):
    """In ``NUMBA_CACHE_DIR``, when it is set."""


class PackageInTreeCacheLocator(_PackageStamp, caching.InTreeCacheLocator):
    """In ``__pycache__`` beside the module."""


class PackageUserWideCacheLocator(_PackageStamp, caching.UserWideCacheLocator):
    """In numba's user-wide cache directory, where the package's folder is read-only."""


LOCATORS = (PackageUserProvidedCacheLocator, PackageInTreeCacheLocator, PackageUserWideCacheLocator)
"""Where the package's kernels are cached: the first of these whose directory is writable."""


def _use_package_stamps() -> None:
    locators = caching.CacheImpl._locator_classes  # numba's cache locators, tried in order
    locators[:] = [*LOCATORS, *(locator for locator in locators if locator not in LOCATORS)]


_use_package_stamps()


def _cache_directory() -> str | None:
    """The directory the package's kernels are cached in (created if missing), or None where none is writable."""
    for locator in LOCATORS:
        found = locator.from_function(_cache_directory, __file__)  # None unless it can write there
        if found is not None:
            return found.get_cache_path()
    return None


CACHE_DIRECTORY = _cache_directory()
"""Where this process caches the kernels of this module's folder (of the others: alike, beside them or in a subfolder
named after them); None: nowhere writable, the kernels compile in memory."""
if CACHE_DIRECTORY is None:
    # One line (logging, as JAX reports its CPU fallback), instead of numba's "no locator available" error.
    logging.getLogger(__name__).warning(
        "rolling_disk_env: no writable directory to cache compiled kernels in (NUMBA_CACHE_DIR, the package's "
        "__pycache__, ~/.cache/numba): they compile in memory, again in every process; set NUMBA_CACHE_DIR to a "
        "writable directory to keep them"
    )

MEMORY_CHECKS = 4096
"""Runtime overlap checks LLVM may emit before a vectorized loop (LLVM's default: 128)."""


def _allow_memory_checks() -> None:
    llvmlite.binding.set_option("rolling_disk_env", f"-vectorize-memory-check-threshold={MEMORY_CHECKS}")


_allow_memory_checks()

kernel = numba.njit(cache=CACHE_DIRECTORY is not None, error_model="numpy")
"""Compiles a function of one disk, or a loop over a batch of disks, cached (where a directory is writable)."""
inline_kernel = numba.njit(cache=CACHE_DIRECTORY is not None, error_model="numpy", forceinline=True)
"""Compiles a function that LLVM inlines into each caller (``alwaysinline``): a per-disk body called in a loop over
the disks, where a call left in the loop would keep it from vectorizing (LLVM's own inliner leaves the larger ones,
the tasks' reward terms and the integrators' steps, as calls). Numba's own inlining (``inline="always"``, which
copies the callee's IR into each caller before typing it) gave the same results to the last bit and no faster steps,
but took about 60% of a step's compile time (``docs/performance/history.md``, ``benchmarks/results/compile.md``)."""
share_kernel = numba.njit(cache=CACHE_DIRECTORY is not None, error_model="numpy", inline="always")
"""Compiles a thin function only as part of the functions that call it (numba copies its code into each caller
before typing it: ``inline="always"``), not as a function of its own. Numba compiles a function called from another
on its own, then links its code into the caller, where LLVM optimizes it and emits machine code for it again: the
Coulomb step's share (``step_contact_share``, which calls its three passes) sat between the passes and the step, so
the passes were compiled once more a configuration (a single env's first ``reset`` and ``step``, nothing cached,
``circle`` with Coulomb: 46.1 -> 41.2 s; ``docs/performance/history.md``). The rolling steps' shares stay kernels
(:data:`kernel`): inlined, their loops inside the step's loop over the shares ran a single env's step 0.8 us slower.
For a per-disk body called many times, numba's inlining costs more than it saves (:data:`inline_kernel`)."""
parallel_kernel = numba.njit(cache=CACHE_DIRECTORY is not None, error_model="numpy", parallel=True)
"""Compiles a function whose ``prange`` loop runs its iterations on numba's threads (``NUMBA_NUM_THREADS``)."""
prange = numba.prange
"""``range`` whose iterations a :data:`parallel_kernel` spreads over threads."""


class CompiledFunction(WrapperAddressProtocol):
    """A kernel compiled for one signature, as numba's first-class functions are passed (its wrapper address
    protocol): the address of its C-callable wrapper, and its signature."""

    def __init__(self, kernel, signature):
        self._signature = signature
        self._address = function_type._get_wrapper_address(kernel, signature)  # numba's own look-up, once

    def __wrapper_address__(self) -> int:
        return self._address

    def signature(self):
        return self._signature


def first_class(kernel, args: tuple):
    """``kernel`` compiled for the types of ``args`` (it must have been: ``Dispatcher.compile``), as a first-class
    function that a kernel takes as an argument and calls through its address (where JIT is disabled, the kernel
    itself).

    A kernel that calls another by name links that one's code into its own, where LLVM optimizes it and emits its
    machine code again: the threaded step of a batch, calling the task's step by name, took as long again to compile as
    the step itself (``docs/performance/history.md``); called through its address, it compiles in a second or two,
    once for every task and contact whose steps take arguments of the same types. Passing the dispatcher itself would
    look its compiled function up at every call (measured: about 100 us); this object hands numba the address it
    keeps (about 5 us a call).
    """
    if not hasattr(kernel, "overloads"):
        return kernel
    signature = tuple(kernel.typeof_pyval(arg) for arg in args)
    return CompiledFunction(kernel, kernel.overloads[signature].signature)
