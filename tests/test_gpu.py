"""The disk on a GPU: ``make_vec(..., device="cuda")`` against the CPU vector env, every task, contact, integrator and
autoreset mode, 64 disks, 200 steps of random actions with resets.

Runs where numba-cuda is installed (the ``[gpu]`` extra), on a GPU, or without one on numba-cuda's simulator
(``NUMBA_ENABLE_CUDASIM=1``: the CUDA kernels run on the CPU, a Python thread a GPU thread, and hand out CPU tensors),
as CI's GPU job runs it (``.ci/run``). The simulator runs the CPU's arithmetic, so there the agreement is to the last
bit; a GPU fuses multiply-adds (NVVM's default, with no switch in numba-cuda), so there it is within 1e-12 relative.
"""

import importlib.util
import os

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium.vector import AutoresetMode

import rolling_disk_env as rd
from tests.test_torch_env import _assert_close, _assert_infos_close, make, paired_rollout

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


@pytest.mark.parametrize("task", [task for task in rd.TASK_IDS if task not in ("upright", "circle", "goto")])
def test_every_task_of_the_ladder_follows_the_cpu(task):
    """The ladder's later tasks, each under its own contact (``ice``: Coulomb's), their task state included (the
    goals and progress that the step updates, in the observation and the rewards)."""
    paired_rollout("cuda", AutoresetMode.NEXT_STEP, RTOL, task=task)


EVENTS = {
    "waypoints": ("reward_waypoint", 200),
    "eight": ("reward_gate", 200),
    "recovery": ("reward_recovered", 300),
    "recovery_sparse": ("reward_recovered", 300),
}
"""The reward term of each task's progress (a waypoint passed, a gate, the recovery held), and the steps in which the
task's baseline makes it happen."""


@pytest.mark.parametrize("task", list(EVENTS))
def test_the_task_state_advances_as_on_the_cpu_where_the_baseline_makes_progress(task):
    """Driven by the task's classical baseline (reading the CPU env's observations; both envs take its actions), the
    disks pass waypoints and gates and recover, so that the step's updates of the task state (the next waypoint or
    gate, the time held upright) are compared with the CPU's where they happen."""
    from agents.baselines import BASELINES

    term, steps = EVENTS[task]
    kwargs = {"num_envs": 16, "vectorization_mode": "vector_entry_point", "task": task}
    ours = gym.make_vec(rd.ENV_ID, device="cuda", info_keys="full", **kwargs)
    theirs = gym.make_vec(rd.ENV_ID, **kwargs)
    ours.reset(seed=5)
    observations, _ = theirs.reset(seed=5)
    agent = BASELINES[task](task=task)
    fired = 0
    for step in range(steps):
        actions, _ = agent.predict(observations, deterministic=True)
        got = ours.step(torch.from_numpy(np.asarray(actions, dtype=np.float32)))
        want = theirs.step(actions)
        observations = want[0]
        for index in range(4):
            expected = want[index].astype(np.float32) if index == 1 else want[index]
            _assert_close(got[index], expected, RTOL, f"step {step} output {index}")
        _assert_infos_close(got[4], want[4], RTOL, f"step {step}")
        fired += int(np.count_nonzero(want[4][term]))
    assert fired >= 2, f"{term} fired {fired} times: the task's progress was not exercised"


@pytest.mark.parametrize(
    "kwargs",
    [
        {"task": "goto", "params_ranges": {"mass": (2.0, 8.0), "gravity": (5.0, 15.0), "radius": (0.5, 1.5)}},
        {"task": "ice", "params_ranges": {"friction_coefficient": (0.05, 0.6), "mass": (3.0, 7.0)}},
    ],
    ids=["goto-m-g-r", "ice-friction"],
)
def test_randomized_disks_are_the_cpus_from_the_same_seed(kwargs):
    """``params_ranges`` on the GPU: the same seed draws the same disks as the CPU vector env (the drawn values in
    ``info`` and ``final_info``, compared with the rest) and they move the same (same-step autoreset: each new
    episode's disk drawn after the last one's outputs are kept)."""
    paired_rollout("cuda", AutoresetMode.SAME_STEP, RTOL, **kwargs)
    envs = make(8, device="cuda", **kwargs)
    info = envs.reset(seed=3)[1]
    for name, (low, high) in kwargs["params_ranges"].items():
        drawn = info[name].cpu().numpy()
        assert np.all((low <= drawn) & (drawn <= high)) and np.unique(drawn).size == 8, name


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
    np.testing.assert_allclose(got[0].cpu().numpy(), want[0], rtol=0.0, atol=RTOL)
    np.testing.assert_allclose(got[1]["state"].cpu().numpy()[mask], want[1]["state"][mask], rtol=0.0, atol=10 * RTOL)


def _device_done() -> None:
    """Waits for the device (on a GPU): a step raises the error of an earlier one once the device has done it."""
    if not SIMULATED:
        torch.cuda.synchronize()


def test_a_non_finite_action_steps_nothing_from_its_step_on_and_the_next_call_raises_naming_it():
    """The device step never waits: the step with the bad action returns (its outputs meaningless), steps no disk, nor
    does any step after it until a step() after the device has done it (or a reset()) raises, naming the step and
    the disks; every disk is where it was. Then the env steps again."""
    envs = make(4, device="cuda")
    observations, _ = envs.reset(seed=0)
    good = torch.zeros((4, 2), device=observations.device)
    envs.step(good)
    before = envs.unwrapped._batch.states.copy()
    bad = good.clone()
    bad[2, 1], bad[3, 0] = float("inf"), float("nan")
    envs.step(bad)  # step 2: queued, not waited for
    _device_done()
    with pytest.raises(ValueError, match=r"step 2 got a non-finite action for 2 sub-environment\(s\), the first 2"):
        envs.step(good)
    np.testing.assert_array_equal(envs.unwrapped._batch.states, before)  # nothing stepped since step 1
    envs.step(bad)
    with pytest.raises(ValueError, match=r"step 3 got a non-finite action"):
        envs.reset(seed=1)  # a reset raises it too
    envs.reset(seed=1)
    envs.step(good)
    assert not np.array_equal(envs.unwrapped._batch.states, before)


def test_under_disabled_autoreset_stepping_an_ended_disk_raises_at_the_next_call():
    envs = make(4, AutoresetMode.DISABLED, "cuda", task="upright", initial_ranges={"theta": (0.45, 0.45)})
    observations, _ = envs.reset(seed=0)
    actions = torch.zeros((4, 2), device=observations.device)
    steps = 0
    while not bool(envs.step(actions)[2].any()):
        steps += 1
    envs.step(actions)  # steps an ended disk: nothing is stepped
    _device_done()
    with pytest.raises(ValueError, match=rf"have ended and autoreset is disabled.*step {steps + 2} stepped none"):
        envs.step(actions)


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


def _forced(num_envs: int, steps: int, mode=AutoresetMode.NEXT_STEP, **kwargs):
    """Steps the GPU env and the numpy vector env under the same random actions, the GPU batch set to the CPU's
    state (lanes, goals, step counts, ended flags, PCG64 states) before each step: yields the step's results of both
    and the GPU's batch, so that each step is compared from the same state (a chaotic fall or a stick-slip switch
    cannot carry a rounding difference from one step into the next)."""
    ours, theirs = make(num_envs, mode, "cuda", **kwargs), make(num_envs, mode, **kwargs)
    ours.reset(seed=11)
    theirs.reset(seed=11)
    device, cpu = ours.unwrapped._batch, theirs.unwrapped
    rng = np.random.default_rng(1)
    for step in range(steps):
        device.load(cpu._batch)
        device.ended.copy_(torch.from_numpy(cpu._ended))
        device.seed(cpu._rngs, np.ones(num_envs, dtype=bool))
        actions = rng.uniform(-1.5, 1.5, theirs.action_space.shape).astype(np.float32)
        yield step, ours.step(torch.from_numpy(actions).to(device.device)), theirs.step(actions), device


@pytest.mark.parametrize(
    "kwargs",
    [{"task": "upright"}, {"task": "goto", **CONTACTS["coulomb"]}, {"task": "circle", **CONTACTS["sliding"]}],
    ids=["upright", "goto-coulomb", "circle-sliding"],
)
def test_each_step_from_the_cpu_state_follows_the_cpu(kwargs):
    """Teacher-forced: every step starts from the CPU's state, so the outputs agree within the rounding of one step."""
    for step, got, want, _ in _forced(48, 100, **kwargs):
        for index in range(4):
            expected = want[index].astype(np.float32) if index == 1 else want[index]
            _assert_close(got[index], expected, RTOL, f"step {step} output {index}")
        _assert_infos_close(got[4], want[4], RTOL, f"step {step}")


def test_same_step_autoreset_on_the_device_keeps_the_last_outputs():
    """SAME_STEP in one launch: the kernel keeps each ending disk's last observation and info before resetting it."""
    ended = 0
    for step, got, want, _ in _forced(32, 90, AutoresetMode.SAME_STEP, task="goto"):
        _assert_infos_close(got[4], want[4], RTOL, f"step {step}")
        ended += int(np.asarray(want[4].get("_final_obs", np.zeros(1, bool))).sum())
    assert ended >= 16, f"only {ended} episodes ended"


def test_a_seed_gives_the_same_bits_run_after_run():
    """The same seed and actions give the same bits twice (Coulomb contact: every disk runs the hybrid)."""
    runs = []
    for _ in range(2):
        envs = make(64, device="cuda", task="circle", **CONTACTS["coulomb"])
        observations, _ = envs.reset(seed=3)
        rng, outputs = np.random.default_rng(2), [observations.cpu().numpy()]
        for _ in range(60):
            actions = torch.from_numpy(rng.uniform(-1, 1, (64, 2)).astype(np.float32)).to(observations.device)
            observations, rewards, terminated, truncated, info = envs.step(actions)
            outputs += [t.cpu().numpy() for t in (observations, rewards, terminated, truncated, info["state"])]
        runs.append(outputs)
    for first, second in zip(*runs):
        np.testing.assert_array_equal(first, second)


def test_the_hybrid_pass_takes_exactly_the_disks_the_rolling_pass_marked():
    """Coulomb on the device: the step's first kernel queues the disks that slide or need more friction than mu (each
    once, the count first), the second runs the hybrid on those only; the disks left out roll, as the CPU's step has
    them (teacher-forced: same state, same actions)."""
    queued_in_all, sliding_in_all = 0, 0
    for step, got, want, device in _forced(64, 40, task="circle", contact="coulomb", friction_coefficient=0.1):
        _assert_infos_close(got[4], want[4], RTOL, f"step {step}")
        queue = device.queue.cpu().numpy()
        queued = queue[1 : 1 + queue[0]]
        assert len(set(queued.tolist())) == len(queued) and np.all((0 <= queued) & (queued < 64))
        sliding = np.flatnonzero(want[4]["sliding"])
        assert set(sliding.tolist()) <= set(queued.tolist()), f"step {step}: a sliding disk was not queued"
        queued_in_all, sliding_in_all = queued_in_all + len(queued), sliding_in_all + len(sliding)
    assert 0 < sliding_in_all <= queued_in_all < 40 * 64, (sliding_in_all, queued_in_all)


class _Crossings:
    """Counts, while on, the package's crossings between host and device and the reads that synchronize."""

    ENTRIES = ("to_device", "to_host", "launch", "wait_for")
    READS = ("__bool__", "item", "cpu", "tolist", "numpy")

    def __init__(self, monkeypatch):
        from rolling_disk_env import gpu

        self.counts, self.on = {}, False
        for name in self.ENTRIES:
            monkeypatch.setattr(gpu, name, self._counted(name, getattr(gpu, name)))
        monkeypatch.setattr(gpu.Launch, "__call__", self._counted("Launch", gpu.Launch.__call__))
        for name in self.READS:
            monkeypatch.setattr(torch.Tensor, name, self._counted(f"Tensor.{name}", getattr(torch.Tensor, name)))

    def _counted(self, name, function):
        def counted(*args, **kwargs):
            if self.on:
                self.counts[name] = self.counts.get(name, 0) + 1
            return function(*args, **kwargs)

        return counted


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda mode: mode.value)
@pytest.mark.parametrize("contact", ["rolling", "coulomb"])
def test_a_step_crosses_nothing_but_its_launches(monkeypatch, contact, mode):
    """A step on the device: the check and the step (under Coulomb: its rolling and hybrid passes) launched through
    their prepared launches, no copy to or from the device through the package, no read of a tensor on the host, no
    wait for the device (the status word is copied asynchronously, read later from pinned memory); a reset by a
    mask on the device likewise launches once and copies nothing."""
    envs = make(16, mode, "cuda", task="goto", **CONTACTS[contact])
    observations, _ = envs.reset(seed=0)
    actions = torch.zeros((16, 2), device=observations.device)
    envs.step(actions)
    crossings = _Crossings(monkeypatch)
    crossings.on = True
    for _ in range(3):
        envs.step(actions)
    assert crossings.counts == {"Launch": 3 * (2 if contact == "rolling" else 3)}
    crossings.counts.clear()
    envs.reset(options={"reset_mask": torch.arange(16, device=observations.device) % 3 == 0})
    assert crossings.counts == {"Launch": 1}


@pytest.mark.skipif(SIMULATED, reason="needs a real GPU: the simulator does not synchronize")
@pytest.mark.parametrize("info_keys", ["training", "full"])
def test_a_step_synchronizes_nothing(info_keys):
    """Under torch's sync debug mode "error", every synchronizing torch call raises: none in five steps (actions on
    the device, float32)."""
    envs = make(1024, device="cuda", task="circle", info_keys=info_keys)
    observations, _ = envs.reset(seed=0)
    actions = torch.zeros((1024, 2), device=observations.device)
    envs.step(actions)
    torch.cuda.set_sync_debug_mode("error")
    try:
        for _ in range(5):
            envs.step(actions)
    finally:
        torch.cuda.set_sync_debug_mode("default")


def test_rsl_rl_env_moves_the_disks_within_their_episodes_and_logs_successes_on_the_device():
    """rsl_rl's ``init_at_random_ep_len`` writes ``episode_length_buf``: the disks' own step counters, so they truncate
    where it says; the success rate of the iteration's ended episodes is logged at its last step."""
    from agents.device_training import RslRlVecEnv

    env = RslRlVecEnv("upright", 8, "cuda", 0, {}, steps_per_iteration=4)
    env.episode_length_buf = torch.tensor([498, 497, 0, 0, 0, 0, 0, 10])
    assert env.episode_length_buf.tolist() == [498, 497, 0, 0, 0, 0, 0, 10]
    actions = torch.zeros((8, 2), device=env.device)
    time_outs = []
    for step in range(4):
        *_, extras = env.step(actions)
        time_outs.append(extras["time_outs"].cpu().numpy())
        assert ("/success_rate" in extras["log"]) == (step == 3)
    ended = np.array(time_outs)
    assert ended[1].tolist() == [True] + [False] * 7 and ended[2].tolist() == [False, True] + [False] * 6
    assert float(extras["log"]["/success_rate"]) == 1.0  # upright: the two truncated episodes had not fallen
    assert env.episode_length_buf.tolist() == [2, 1, 4, 4, 4, 4, 4, 14]


@pytest.mark.parametrize("contact", ["rolling", "coulomb"])
def test_the_training_set_gives_the_cpus_outputs(contact):
    """The device's training-set kernels (the default of the torch env): the observations, rewards, flags, success and
    codes of the CPU's full step, from the same seed under the same actions."""
    ours, theirs = (
        make(32, device="cuda", task="goto", info_keys="training", **CONTACTS[contact]),
        make(32, task="goto", **CONTACTS[contact]),
    )
    observations, info = ours.reset(seed=7)
    theirs.reset(seed=7)
    assert set(info) == {"is_success", "_is_success", "termination", "_termination"}
    rng = np.random.default_rng(0)
    for step in range(60):
        actions = rng.uniform(-1.5, 1.5, (32, 2)).astype(np.float32)
        got, want = ours.step(torch.from_numpy(actions).to(observations.device)), theirs.step(actions)
        for index in range(4):
            expected = want[index].astype(np.float32) if index == 1 else want[index]
            _assert_close(got[index], expected, RTOL, f"step {step} output {index}")
        for key in ("is_success", "termination"):
            _assert_close(got[4][key], want[4][key], RTOL, f"step {step} {key}")
