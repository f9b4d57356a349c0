"""Every generated CUDA kernel builds for an H100 (sm_90), without a GPU: ``numba.cuda.compile_ptx`` runs NVVM (which
``numba-cuda[cu13]`` installs) on the kernels of ``_generated/cuda.py`` with the types of a GPU batch's arrays. And
``device="cuda"`` without a GPU says what is missing. Runs where numba-cuda is installed, without its simulator (CI's
GPU job: ``.ci/run``)."""

import importlib.util
import os
from types import SimpleNamespace

import numba
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env import codegen
from rolling_disk_env.constants import ENGINE_METHODS, INFO_SETS, set_suffix
from rolling_disk_env.envs.batch import DiskBatch
from rolling_disk_env.envs.config import EnvConfig
from tests.test_torch_env import make

if importlib.util.find_spec("numba_cuda") is None or os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
    pytest.skip("needs numba-cuda without its simulator (CI's GPU job runs these)", allow_module_level=True)

from numba import cuda

from rolling_disk_env import gpu
from rolling_disk_env._generated import cuda as kernels

H100 = (9, 0)
"""The compute capability compiled for."""


class _DeviceLayout(DiskBatch):
    """A CPU batch laid out as the GPU's (a share a disk), whose arrays have the types of the device arrays."""

    _layout = gpu.DeviceBatch._layout


def _arguments(config: EnvConfig, name: str, num_envs: int = 256) -> tuple:
    """The argument of kernel ``name`` (a step or the reset) on a batch of ``config``, as host arrays."""
    batch = _DeviceLayout(config, num_envs, 500)
    arrays = batch.shares()
    resets = (np.zeros(num_envs, bool), np.zeros((num_envs, 4), np.uint64), batch.uniforms, batch.no_state)
    out = batch.outputs().shares
    if name.startswith("reset"):
        return resets, arrays, tuple(batch.setup), out
    actions = np.zeros((num_envs, config.action_space.shape[0]), np.float32)
    control = rd.engine.DeviceControl(
        status=np.zeros(3, np.int64),
        ended=np.zeros(num_envs, bool),
        rewards=np.zeros(num_envs, np.float32),
        dones=np.zeros((2, num_envs), bool),
        final=batch.outputs().shares,
        final_mask=np.zeros(num_envs, bool),
        final_disk=np.zeros((rd.engine.DISK_CONSTANTS, num_envs)),
        mode=rd.engine.SAME_STEP,
        queue=np.zeros(num_envs + 1, np.int64),
    )
    return actions, arrays, tuple(batch.setup), out, resets, tuple(control)


STEPS = (*(f"step_{method}" for method in ENGINE_METHODS), "step_contact", "step_contact_hybrid")
"""The step kernels of a task, each in a variant an info set."""
KERNELS = [
    (task, name)
    for task in sorted(rd.TASK_IDS)
    for name in (
        *codegen.CUDA_RESETS,
        *(f"{step}{set_suffix(info_keys)}" for step in STEPS for info_keys in INFO_SETS),
    )
    if hasattr(kernels, f"{task}_{name}")  # the contact families of each task (codegen.contact_families)
]


@pytest.mark.parametrize(("task", "name"), KERNELS, ids=[f"{task}_{name}" for task, name in KERNELS])
def test_every_kernel_builds_for_sm_90(task, name, monkeypatch):
    contact = {"contact": "coulomb", "friction_coefficient": 0.2} if "contact" in name else {}
    config = EnvConfig.from_kwargs(task=task, **contact)
    arguments = _arguments(config, name)
    # numba-cuda asks the current device for its compute capability where a kernel calls a CPU-compiled function;
    # without a GPU, it is the one compiled for.
    monkeypatch.setattr(numba.cuda.dispatcher, "get_current_device", lambda: SimpleNamespace(compute_capability=H100))
    ptx, _ = cuda.compile_ptx(getattr(kernels, f"{task}_{name}"), (numba.typeof(arguments),), cc=H100)
    assert ".target sm_90" in ptx and ".entry" in ptx


def test_the_check_and_the_seeding_build_for_sm_90(monkeypatch):
    monkeypatch.setattr(numba.cuda.dispatcher, "get_current_device", lambda: SimpleNamespace(compute_capability=H100))
    check = (numba.float32[:, ::1], numba.boolean[::1], numba.boolean, numba.int64[::1], numba.int64[::1])
    seed = (numba.types.Tuple((numba.uint64, numba.uint64, numba.boolean[::1], numba.uint64[:, ::1])),)
    for function, types in ((gpu._check, check), (gpu._seed, seed)):
        ptx, _ = cuda.compile_ptx(function, types, cc=H100)
        assert ".target sm_90" in ptx and ".entry" in ptx


@pytest.mark.skipif(cuda.is_available(), reason="this machine has a GPU")
def test_cuda_without_a_gpu_says_what_is_missing():
    with pytest.raises(RuntimeError, match=r"found no CUDA GPU.*nvidia-smi"):
        make(2, device="cuda")
