"""The disk on a GPU: ``make_vec(..., device="cuda")`` against the CPU vector env, every task, contact, integrator and
autoreset mode, 64 disks, 200 steps of random actions with resets.

Runs where numba-cuda is installed (the ``[gpu]`` extra), on a GPU, or without one on numba-cuda's simulator
(``NUMBA_ENABLE_CUDASIM=1``: the CUDA kernels run on the CPU, a Python thread a GPU thread, and hand out CPU tensors),
as CI's GPU job runs it (``.ci/run``). The simulator runs the CPU's arithmetic, so there the agreement is to the last
bit; a GPU fuses multiply-adds (NVVM's default, with no switch in numba-cuda), so there it is within 1e-12 relative.
"""

import importlib.util
import os

import numpy as np
import pytest
import torch
from gymnasium.vector import AutoresetMode

from tests.test_torch_env import make, paired_rollout

SIMULATED = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
if importlib.util.find_spec("numba_cuda") is None:
    pytest.skip("numba-cuda is not installed (the [gpu] extra; CI runs these in its GPU job)", allow_module_level=True)
if not SIMULATED:
    from numba import cuda

    if not cuda.is_available():
        pytest.skip("no CUDA GPU: NUMBA_ENABLE_CUDASIM=1 runs these on numba-cuda's simulator", allow_module_level=True)

RTOL = 0.0 if SIMULATED else 1e-12
"""Agreement with the CPU, relative to each output's largest value."""
CONTACTS = {
    "rolling": {},
    "sliding": {"contact": "sliding", "friction_coefficient": 0.3},
    "coulomb": {"contact": "coulomb", "friction_coefficient": 0.2},
}


@pytest.mark.parametrize("contact", list(CONTACTS))
@pytest.mark.parametrize("task", ["upright", "circle", "goto"])
def test_every_task_and_contact_follows_the_cpu(task, contact):
    paired_rollout("cuda", AutoresetMode.NEXT_STEP, RTOL, task=task, **CONTACTS[contact])


@pytest.mark.parametrize("mode", [AutoresetMode.SAME_STEP, AutoresetMode.DISABLED], ids=lambda mode: mode.value)
@pytest.mark.parametrize("contact", ["rolling", "coulomb"])
def test_every_autoreset_mode_follows_the_cpu(contact, mode):
    paired_rollout("cuda", mode, RTOL, task="circle", **CONTACTS[contact])


@pytest.mark.parametrize("integrator", ["euler", "symplectic_euler", "dopri5"])
def test_every_integrator_follows_the_cpu(integrator):
    paired_rollout("cuda", AutoresetMode.NEXT_STEP, RTOL, task="goto", integrator=integrator, substeps=2)


def test_seeds_states_and_partial_resets_as_the_cpu_env():
    ours, theirs = make(8, device="cuda", task="goto"), make(8, task="goto")
    ours.reset(seed=[5, 4, 6, 7, 8, 9, 10, 11])
    theirs.reset(seed=[5, 4, 6, 7, 8, 9, 10, 11])
    state = make(8, task="goto").reset(seed=3)[1]["state"] * 0.5  # states of other episodes
    mask = np.arange(8) % 2 == 0
    got = ours.reset(options={"state": torch.from_numpy(state), "reset_mask": torch.from_numpy(mask)})
    want = theirs.reset(options={"state": state, "reset_mask": mask})
    np.testing.assert_array_equal(got[0].cpu().numpy(), want[0])
    np.testing.assert_array_equal(got[1]["state"].cpu().numpy()[mask], want[1]["state"][mask])


def test_non_finite_actions_raise_and_step_nothing():
    envs = make(4, device="cuda")
    observations, _ = envs.reset(seed=0)
    actions = torch.zeros((4, 2), device=observations.device)
    actions[2, 1] = float("inf")
    before = envs.unwrapped._batch.states.copy()
    with pytest.raises(ValueError, match=r"finite numbers.*sub-environment 2"):
        envs.step(actions)
    np.testing.assert_array_equal(envs.unwrapped._batch.states, before)  # nothing stepped
    assert torch.equal(envs.step(torch.zeros_like(actions))[4]["_state"], torch.ones(4, dtype=torch.bool))
    assert not np.array_equal(envs.unwrapped._batch.states, before)


def test_a_partial_reset_after_steps_in_inference_mode():
    """rsl_rl steps under ``torch.inference_mode()``; the flags kept from those steps must not break a reset after."""
    envs = make(4, device="cuda")
    observations, _ = envs.reset(seed=0)
    with torch.inference_mode():
        for _ in range(3):
            envs.step(torch.zeros((4, 2), device=observations.device))
    envs.reset(options={"reset_mask": torch.tensor([True, False, True, False])})
    envs.step(torch.zeros((4, 2), device=observations.device))


@pytest.mark.skipif(SIMULATED, reason="needs a real GPU: the simulator hands out CPU tensors")
def test_tensors_live_on_the_gpu_and_actions_on_the_cpu_are_moved_there():
    envs = make(256, device="cuda", task="circle")
    observations, info = envs.reset(seed=0)
    assert observations.device.type == "cuda" and info["state"].device.type == "cuda"
    observations, rewards, terminated, truncated, info = envs.step(np.zeros((256, 2), dtype=np.float64))
    assert all(t.device.type == "cuda" for t in (observations, rewards, terminated, truncated, info["energy"]))
