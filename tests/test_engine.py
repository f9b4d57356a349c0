"""The compiled engine: compiled kernels equal the interpreted generated code, numba's cache follows the package's
sources and works where the package is read-only, stale task steps are refused (PCG64 against numpy: test_pcg64)."""

import json
import multiprocessing
import os
import shutil
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env import engine, jit
from rolling_disk_env.envs.batch import THREADS_FROM, ThreadChoice, columns, task_steps, thread_count
from rolling_disk_env.tasks import TASKS

ROOT = Path(__file__).resolve().parents[1]

# Runs in a fresh interpreter, compiled or (NUMBA_DISABLE_JIT=1) interpreted: the model on random states, each
# integrator's step, PCG64 draws, and episodes of every task in the single and the vector env.
PROGRAM = """
import json, sys, warnings
import gymnasium as gym, numpy as np
import rolling_disk_env as rd
from rolling_disk_env import engine, pcg64
from rolling_disk_env.tasks import TASKS
from gymnasium.utils import seeding

warnings.filterwarnings("ignore", "overflow", RuntimeWarning)  # PCG64's intended wrap-around, interpreted
rng = np.random.default_rng(7)
states = rng.uniform(-2, 2, (20, 8))
states[:, 3] = rng.uniform(-1.3, 1.3, 20)
torques = rng.uniform(-5, 5, (20, 2))
disks = np.tile([5.0, 9.81, 1.0], (20, 1))
out = {"derivatives": rd.state_derivative(states, torques).tolist()}
values = np.empty((20, 5))
engine.diagnostics(states, torques, disks, values)
out["diagnostics"] = values.tolist()
for method in range(4):
    x, status = states.copy(), np.zeros(20, dtype=np.int8)
    engine.advance(method, x, torques, disks, 0.01, np.full(20, 0.01), 1e-9, 1e-9, status)
    out[engine.METHODS[method]] = x.tolist()
words = pcg64.state_words(seeding.np_random(3)[0])
out["pcg64"] = [pcg64.random(words) for _ in range(10)]
actions = rng.uniform(-1.2, 1.2, (40, 2)).astype(np.float32)
for task in sorted(TASKS):
    env = gym.make("RollingDisk-v0", task=task, max_episode_steps=15)
    env.reset(seed=1)
    trace = []
    for action in actions:
        observation, reward, terminated, truncated, info = env.step(action)
        trace.append([*observation.tolist(), reward, *info["state"].tolist()])
        if terminated or truncated:
            env.reset()
    vector = rd.RollingDiskVectorEnv(num_envs=3, max_episode_steps=15, task=task)
    vector.reset(seed=2)
    for action in actions:
        observations, rewards, *_ = vector.step(np.tile(action, (3, 1)))
        trace.append([*observations.ravel().tolist(), *rewards.tolist()])
    out[task] = trace
json.dump(out, sys.stdout)
"""


def _run(disable_jit: bool) -> dict:
    environment = {**os.environ, "NUMBA_DISABLE_JIT": "1" if disable_jit else "0"}
    result = subprocess.run(
        [sys.executable, "-c", PROGRAM], capture_output=True, text=True, env=environment, cwd=ROOT, timeout=600
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout)


def test_compiled_kernels_give_the_interpreted_generated_code_to_the_last_bit():
    compiled, interpreted = _run(False), _run(True)
    assert set(compiled) == set(interpreted) >= {"derivatives", "rk4", "dopri5", "pcg64", *TASKS}
    for key in compiled:  # JSON keeps every float's exact value
        assert compiled[key] == interpreted[key], key


def test_the_package_stamp_changes_with_any_source_file(tmp_path):
    copy = tmp_path / "rolling_disk_env"
    shutil.copytree(jit.PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    code = "from rolling_disk_env import jit; print(jit.package_stamp())"

    def stamp():
        return subprocess.check_output([sys.executable, "-c", code], cwd=tmp_path, text=True).strip()

    before = stamp()
    tasks = copy / "tasks" / "upright.py"
    tasks.write_text(tasks.read_text() + "\n")
    assert stamp() != before


def test_kernels_cache_in_the_user_directory_when_the_package_is_read_only(tmp_path):
    package, home = tmp_path / "site" / "rolling_disk_env", tmp_path / "home"
    shutil.copytree(jit.PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    folders = [package, *(path for path in package.rglob("*") if path.is_dir())]
    if os.geteuid() == 0:
        # Root writes through permission bits: block the cache folders themselves, as numba sees a read-only tree.
        for folder in folders:
            (folder / "__pycache__").write_text("")
    else:
        for folder in folders:
            folder.chmod(0o555)
    environment = {**os.environ, "HOME": str(home), "NUMBA_DEBUG_CACHE": "1", "PYTHONDONTWRITEBYTECODE": "1"}
    environment.pop("NUMBA_CACHE_DIR", None)
    code = "from rolling_disk_env import engine; print(engine.steady_circle(4.0, 2.0, 9.81, 1.0))"
    try:
        runs = [
            subprocess.run(
                [sys.executable, "-c", code], cwd=package.parent, env=environment, capture_output=True, text=True
            )
            for _ in range(2)
        ]
    finally:
        for folder in folders:
            folder.chmod(0o755)
    assert all(run.returncode == 0 for run in runs), runs[0].stderr[-2000:]
    assert "data saved" in runs[0].stdout and "data loaded" in runs[1].stdout
    assert f"from '{home}" in runs[1].stdout  # numba's user-wide cache directory


def test_steps_of_an_edited_task_are_refused(monkeypatch):
    steps = task_steps(TASKS["upright"]())
    monkeypatch.setattr(steps, "TASK_SOURCE", "0" * 64)
    with pytest.raises(RuntimeError, match="codegen"):
        rd.RollingDiskEnv(task="upright")


def test_importing_the_envs_compiles_nothing_until_a_config_is_used():
    code = (
        "import rolling_disk_env, gymnasium as gym; env = gym.make('RollingDisk-v0'); "
        "from rolling_disk_env._generated import upright, circle; "
        "print(len(upright.step_rk4_share.signatures), len(upright.step_euler_share.signatures), "
        "len(circle.step_rk4_share.signatures))"
    )
    env_step = "env.reset(seed=0); env.step(env.action_space.sample()); "
    code = code.replace("from rolling", env_step + "from rolling")
    assert subprocess.check_output([sys.executable, "-c", code], cwd=ROOT, text=True).split() == ["1", "0", "0"]


@pytest.mark.parametrize("num_envs", [1, 255, 256, 4096, 4100, 16384])
def test_a_large_batch_has_shares_of_rows_of_an_odd_number_of_cache_lines(num_envs):
    width = columns(num_envs)
    if num_envs < 256:
        assert width == num_envs
    else:
        assert num_envs <= width <= num_envs + 16 and width % 8 == 0 and (width // 8) % 2 == 1
    # circle: the task whose batches test_vector_env steps on threads too (its step compiled once for both files)
    env = rd.RollingDiskVectorEnv(num_envs=num_envs, task="circle")
    batch = env._batch
    assert batch.threads == (jit.numba.get_num_threads() if num_envs >= THREADS_FROM else 1)
    assert batch.share == columns(-(-num_envs // batch.threads))
    assert batch.lanes.shape == (engine.LANES, batch.threads * batch.share)
    observations, infos = env.reset(seed=0)
    assert observations.shape == (num_envs, 8) and infos["energy"].shape == (num_envs,)
    observations, rewards, terminated, _, infos = env.step(np.zeros((num_envs, 2), dtype=np.float32))
    assert observations.shape == (num_envs, 8) and rewards.shape == terminated.shape == (num_envs,)
    assert np.all(np.isfinite(observations)) and np.all(np.isfinite(rewards))


@pytest.mark.parametrize("integrator", ["dopri5", "rk4"])
def test_the_padding_of_a_batch_takes_ordinary_steps(integrator):
    # Padding columns are idle disks at rest: with a step size of 0 s, dopri5 would run to its substep limit on them;
    # with the sines and cosines of their state (lanes rows ANGLES) left at 0, cos(theta) = 0 would make RK4's NaN.
    env = rd.RollingDiskVectorEnv(num_envs=256, integrator=integrator)
    env.reset(seed=0)
    batch = env._batch
    out = batch.outputs()
    batch.step(np.zeros((256, 2), dtype=np.float32), out)
    padding = out.blocks[3][256:]  # the termination codes
    assert len(padding) > 0 and np.all(padding == 0)


def test_the_observations_are_copied_into_each_disks_row():
    info = np.random.default_rng(0).normal(size=(12, 2, 5))
    observations = np.zeros((2, 5, 4), dtype=np.float32)
    engine.transpose.py_func(info, 3, 4, observations, 1)
    np.testing.assert_array_equal(observations[1], info[3:7, 1].T.astype(np.float32))
    assert not observations[0].any()


def test_a_batch_steps_with_and_without_resets_in_either_order():
    # A batch steps with resets (the vector env's) and without (the single env's) through one compiled function, its
    # resets in the batch's bundle: a step without after a step with, and back, gives the twin's states.
    envs = [rd.RollingDiskVectorEnv(num_envs=4) for _ in range(2)]
    actions = np.full((4, 2), 0.5, dtype=np.float32)
    for env in envs:
        env.reset(seed=1)
        env.step(actions)  # the vector env passes its resets (none here)
    batch, twin = envs[0]._batch, envs[1]._batch
    batch.step(actions, batch.outputs())  # as the single env steps: no resets
    envs[1].step(actions)
    np.testing.assert_array_equal(batch.states, twin.states)
    envs[0].step(actions)
    envs[1].step(actions)
    np.testing.assert_array_equal(batch.states, twin.states)
    assert not np.array_equal(batch.states[:, :4], np.tile(batch.states[:, :1], 4))  # four different disks


@pytest.mark.parametrize("substeps", [1, 3])
@pytest.mark.parametrize("integrator", ["euler", "symplectic_euler", "rk4"])
def test_the_vector_envs_steps_are_the_model_apis_to_the_last_bit(integrator, substeps):
    # The fused step starts each disk's step from the sines and cosines of its state kept from the end of the last
    # step or its reset (lanes rows ANGLES); the model API's loop computes them from the state. Through autoresets
    # and a reset of some disks to given states, one kept from a state that has since changed would show here.
    num_envs, method = 5, engine.METHODS.index(integrator)
    env = rd.RollingDiskVectorEnv(num_envs=num_envs, integrator=integrator, substeps=substeps, max_episode_steps=6)
    env.reset(seed=4)
    batch, rng = env._batch, np.random.default_rng(4)
    dt, disks = env.unwrapped.config.dt / substeps, np.ascontiguousarray(batch.disks.T)
    resetting, compared = np.zeros(num_envs, dtype=bool), 0
    for t in range(20):
        if t == 9:
            given = rng.uniform(-0.3, 0.3, (num_envs, 8))
            env.reset(options={"reset_mask": np.array([True, False, True, False, False]), "state": given})
            resetting[[0, 2]] = False
        states = np.ascontiguousarray(batch.states.T)
        actions = rng.uniform(-1.0, 1.0, (num_envs, 2)).astype(np.float32)
        _, _, terminated, truncated, _ = env.step(actions)
        torques = np.ascontiguousarray(batch.lanes[engine.TAU_SPIN : engine.TAU_STEER + 1, :num_envs].T)
        status = np.zeros(num_envs, dtype=np.int8)
        for _ in range(substeps):
            engine.advance(method, states, torques, disks, dt, np.full(num_envs, dt), 1e-9, 1e-9, status)
        stepped = ~resetting
        assert np.all(status[stepped] == engine.RUNNING)
        np.testing.assert_array_equal(batch.states.T[stepped], states[stepped])
        resetting, compared = terminated | truncated, compared + stepped.sum()
    assert compared >= 60


@pytest.mark.parametrize("substeps", [1, 3])
@pytest.mark.parametrize("integrator", ["euler", "symplectic_euler", "rk4"])
def test_a_step_that_leaves_the_domain_ends_where_its_period_started(integrator, substeps):
    # Disk 0 leans past LEAN_LIMIT within the period (dtheta 100 rad/s from theta = 1 rad); its step ends with
    # OUT_OF_DOMAIN at the state the period started from, not at a substep's, whatever the substeps. Disks 1 and 2
    # step on as the model API steps them.
    env = rd.RollingDiskVectorEnv(
        num_envs=3, integrator=integrator, substeps=substeps, task_options={"fall_lean": rd.LEAN_LIMIT - 1e-3}
    )
    given = np.array(
        [[0.5, -0.2, 0.3, 1.0, 0.1, 2.0, 100.0, 0.5], [0, 0, 0, 0.1, 0, 2.0, 0, 0], [1, 2, 0, -0.1, 1, 3, 0, 0]]
    )
    env.reset(seed=0, options={"state": given})
    actions = np.array([[0.5, -0.5], [0.2, 0.1], [-0.3, 0.4]], dtype=np.float32)
    _, _, terminated, _, info = env.step(actions)
    assert info["termination"].tolist() == [
        rd.Termination.OUT_OF_DOMAIN,
        rd.Termination.NONE,
        rd.Termination.NONE,
    ]
    assert terminated.tolist() == [True, False, False]
    np.testing.assert_array_equal(info["state"][0], given[0])
    batch, dt = env._batch, env.unwrapped.config.dt / substeps
    states, status = np.ascontiguousarray(given[1:]), np.zeros(2, dtype=np.int8)
    torques = np.ascontiguousarray(batch.lanes[engine.TAU_SPIN : engine.TAU_STEER + 1, 1:3].T)
    disks = np.ascontiguousarray(batch.disks.T[1:3])
    for _ in range(substeps):
        engine.advance(engine.METHODS.index(integrator), states, torques, disks, dt, np.full(2, dt), 1e-9, 1e-9, status)
    assert np.all(status == engine.RUNNING)
    np.testing.assert_array_equal(info["state"][1:], states)


def test_a_child_process_steps_on_one_thread():
    # SubprocVecEnv's children share the cores with their siblings: each steps its batch on the calling thread.
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        assert pool.apply(thread_count, (THREADS_FROM,)) == 1
    assert thread_count(THREADS_FROM) == jit.numba.get_num_threads()
    assert thread_count(THREADS_FROM - 1) == 1


def test_gym_make_env_is_the_engines_env():
    assert isinstance(gym.make(rd.ENV_ID).unwrapped, rd.RollingDiskEnv)


def run_choice(choice: ThreadChoice, steps: int, seconds) -> list[bool]:
    """The ways ``choice`` takes for ``steps`` steps whose times ``seconds(threaded)`` gives."""
    ways = []
    for _ in range(steps):
        threaded = choice.next()
        choice.record(threaded, seconds(threaded))
        ways.append(threaded)
    return ways


def test_thread_choice_takes_the_faster_way_and_follows_a_change_of_load():
    assert run_choice(ThreadChoice(), 6, lambda way: 1.0) == [False] * 3 + [True] * 3  # a probe of each way
    choice = ThreadChoice()
    # Another process on a core: a threaded step waits for a preempted thread (35 serial steps, as measured at
    # N = 4096). The probes cost at most ThreadChoice.BUDGET of the time, beyond the start's and the last one's (three
    # threaded steps each).
    serial, threaded = 0.2e-3, 7e-3
    busy = run_choice(choice, 20_000, lambda way: threaded if way else serial)
    spent = busy.count(True) * threaded + busy.count(False) * serial
    assert spent <= (1 + ThreadChoice.BUDGET) * len(busy) * serial + 6 * threaded  # probes backing off by doubling
    # from every 32 steps to every 2048 cost 6%
    assert busy.count(True) >= 6  # but it does probe
    assert not any(busy[-100:])
    # The load ends: the threads step twice as fast, found at the next probe and kept, serial probes aside.
    idle = run_choice(choice, ThreadChoice.PROBE_AT_MOST + 1000, lambda way: 0.1e-3 if way else serial)
    assert idle[-1000:].count(True) >= 0.95 * 1000


def test_thread_choice_charges_the_start_for_all_its_steps():
    """Beside a busy core the start's threaded steps each wait for a preempted thread (as measured at N = 4096: 0.29
    ms a serial step, threaded ones up to 34 ms): the first probe comes only once the steps since have taken the start's
    loss over ThreadChoice.BUDGET (it came 6 times too early here while the start counted its fastest threaded
    step alone)."""
    serial, start = 0.29e-3, [30e-3, 20e-3, 10e-3]  # the start's three threaded steps (steps 4 to 6)
    choice, ways = ThreadChoice(), []
    for _ in range(20_000):
        way = choice.next()
        choice.record(way, start[len(ways) - 3] if 3 <= len(ways) < 6 else (20e-3 if way else serial))
        ways.append(way)
    steps = ways.index(True, 2 * ThreadChoice.PROBE_STEPS) + 1 - 2 * ThreadChoice.PROBE_STEPS  # to the probe's first
    loss = sum(start) - 3 * serial
    assert steps * serial * ThreadChoice.BUDGET >= loss


def test_thread_choice_does_not_time_the_first_step_of_a_probe():
    """After a spell on the calling thread, the first threaded step waits for numba's sleeping threads: a probe
    timed by that step alone would keep the batch off threads that step it faster (it does if the first step of a
    way is timed)."""
    choice, ways = ThreadChoice(), []
    for _ in range(1000):
        threaded = choice.next()
        waking = threaded and ways and not ways[-1]
        choice.record(threaded, 3e-3 if waking else (0.6e-3 if threaded else 1e-3))
        ways.append(threaded)
    assert ways[-500:].count(True) >= 0.95 * 500  # on the threads but for probes


def test_thread_choice_times_a_probe_by_its_fastest_step():
    """A probe slowed once by the machine's other load does not keep the batch off the faster threads (a probe timed
    by one step does)."""
    choice, ways = ThreadChoice(), []
    for _ in range(2000):
        threaded = choice.next()
        # Serial steps take 1 ms, threaded ones 0.6 ms, but both timed threaded steps of the start and the first
        # timed one of each probe 14 ms (a vCPU descheduled for a while): the start chooses the calling thread.
        start = ThreadChoice.PROBE_STEPS + 1 < choice.steps <= 2 * ThreadChoice.PROBE_STEPS
        held_up = threaded and (start or choice.steps == choice.next_probe + 1)
        choice.record(threaded, 14e-3 if held_up else (0.6e-3 if threaded else 1e-3))
        ways.append(threaded)
    assert not ways[2 * ThreadChoice.PROBE_STEPS]
    # The start's loss (its three threaded steps, 25.6 ms beyond three serial ones) puts the first probe 1280 steps
    # later (ThreadChoice.BUDGET); it finds the threads.
    assert ways[-500:].count(True) >= 0.95 * 500


def test_thread_choice_stays_on_the_threads_through_single_held_up_steps():
    """A threaded step now and then held up for 14 ms (the machine's hypervisor descheduling a vCPU) on an idle
    machine does not take the batch off the threads, which step it twice as fast (it did for some 35 steps each time
    while a step counted in full in the moving average)."""
    choice, ways = ThreadChoice(), []
    for step in range(3000):
        threaded = choice.next()
        choice.record(threaded, (14e-3 if step % 300 == 150 else 0.4e-3) if threaded else 0.8e-3)
        ways.append(threaded)
    assert ways[100:].count(True) >= 0.97 * 2900


@pytest.mark.parametrize("columns", [1, 2])
def test_the_first_row_with_a_nan_or_inf_is_found_wherever_it_is(columns):
    # The check counts non-finite values in a vectorized loop before it searches: put them where the loop's vector
    # body reads them (not only its scalar remainder), next to the float32 extremes that are finite.
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (1001, columns)).astype(np.float32)
    extremes = np.finfo(np.float32)
    actions[3, 0], actions[4, -1], actions[5, 0] = extremes.max, -extremes.max, extremes.smallest_subnormal
    actions[6, -1] = -0.0
    assert engine.first_nonfinite(actions) == -1
    for value in (np.nan, -np.nan, np.inf, -np.inf):
        for rows in ([0], [517, 800], [1000]):
            bad = actions.copy()
            bad[rows, -1] = value
            expected = int(np.flatnonzero(~np.isfinite(bad).all(axis=1))[0])
            assert engine.first_nonfinite(bad) == expected == rows[0]
