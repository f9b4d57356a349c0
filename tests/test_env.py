"""RollingDisk-v0 against Gymnasium's and SB3's conventions, the model, and bad input."""

import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import rolling_disk_env as rd
from rolling_disk_env.tasks import TASKS

ACTUATOR_SETS = [(), ("spin",), ("steer",), ("spin", "steer")]
SCENARIO_1 = np.array([2, 0, 0, 0.1, 0, 2.5, 0, 0])


def make(**kwargs):
    return gym.make(rd.ENV_ID, **kwargs)


@pytest.mark.parametrize("task", sorted(TASKS))
@pytest.mark.parametrize("actuators", ACTUATOR_SETS)
def test_gymnasium_checker_passes_with_warnings_as_errors(task, actuators):
    env = make(task=task, actuators=actuators)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("task", sorted(TASKS))
@pytest.mark.parametrize("actuators", ACTUATOR_SETS)
def test_stable_baselines3_checker_passes_with_warnings_as_errors(task, actuators):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make(task=task, actuators=actuators)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_check_env(env.unwrapped, warn=True)


def test_registration_and_the_module_prefixed_id_work_in_a_fresh_interpreter():
    code = (
        "import gymnasium as gym; env = gym.make('rolling_disk_env:RollingDisk-v0'); "
        "print(env.spec.max_episode_steps, env.spec.reward_threshold)"
    )
    assert subprocess.check_output([sys.executable, "-c", code], text=True).split() == ["500", "450.0"]


def test_registration_is_idempotent():
    import importlib

    importlib.reload(rd)
    assert gym.spec(rd.ENV_ID).vector_entry_point == "rolling_disk_env.envs:vector_env"


def _rollout(env, seed, steps, action_seed=0):
    env.action_space.seed(action_seed)
    observation, info = env.reset(seed=seed)
    trace = [(observation, 0.0, False, False, info["state"])]
    for _ in range(steps):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        trace.append((observation, reward, terminated, truncated, info["state"]))
        if terminated or truncated:
            observation, info = env.reset()
            trace.append((observation, 0.0, False, False, info["state"]))
    return trace


@pytest.mark.parametrize("task", sorted(TASKS))
def test_same_seed_same_trajectory_other_seed_another(task):
    first = _rollout(make(task=task), seed=7, steps=300)
    second = _rollout(make(task=task), seed=7, steps=300)
    other = _rollout(make(task=task), seed=8, steps=300)
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[4], b[4])
        assert a[1:4] == b[1:4]
    assert not np.array_equal(first[0][4], other[0][4])


def test_step_types_are_the_ones_sb3_accepts():
    env = make()
    observation, info = env.reset(seed=0)
    observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
    assert observation.dtype == np.float32 and observation in env.observation_space
    assert info["state"].dtype == np.float64 and info["state"].shape == (8,)
    assert type(info["is_success"]) is bool
    terms = env.unwrapped.task.reward_weights
    assert {key for key in info if key.startswith("reward_")} == {f"reward_{term}" for term in terms}
    assert reward == sum(w * info[f"reward_{t}"] for t, w in env.unwrapped.task.reward_weights.items())
    assert not any(isinstance(value, dict) for value in info.values())  # flat, for batching wrappers
    assert env.unwrapped.dt == 0.02 and env.metadata["render_fps"] == 50


def test_info_reports_the_model_energy_and_contact_force():
    env = make(actuators=("spin", "steer"))
    env.reset(seed=3)
    _, _, _, _, info = env.step(np.array([0.4, -0.6], dtype=np.float32))
    assert info["energy"] == pytest.approx(rd.energy(info["state"]))
    np.testing.assert_allclose(info["contact_force"], rd.contact_force(info["state"], [0.4 * 5.0, -0.6 * 10.0]))


def test_passive_episode_from_scenario_1_matches_dop853():
    # RK4 at the env's dt = 0.02 s has a global error near 1.4e-6 after 10 s here (benchmarks/results: it scales
    # as dt^4), so 5e-6 on every component bounds it with room for round-off, and a wrong torque mapping, step or
    # substep count would exceed it by orders of magnitude.
    env = make(actuators=())
    _, info = env.reset(seed=0, options={"state": SCENARIO_1})
    states = [info["state"]]
    truncated = False
    while not truncated:
        _, _, terminated, truncated, info = env.step(np.zeros(0, dtype=np.float32))
        assert not terminated
        states.append(info["state"])
    _, reference = rd.simulate(SCENARIO_1, 10.0, 0.02, method="dop853", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.array(states), reference, atol=5e-6, rtol=0)


def test_torques_follow_the_actions_and_are_clipped():
    env = make(actuators=("steer",)).unwrapped
    env.reset(seed=0, options={"state": [0, 0, 0, 0, 0, 0, 0, 0]})
    env.step(np.array([3.0], dtype=np.float32))
    # Pure steer from rest, upright: ddpsi = 4 tau / (m r^2) with tau clipped to 10 N m, so dpsi = 8 dt.
    state = env._batch.states[:, 0]
    assert state[7] == pytest.approx(4 * 10.0 / 5.0 * 0.02)
    assert state[5] == pytest.approx(0.0)


@pytest.mark.parametrize(
    ("action", "message"),
    [
        (np.array([np.nan, 0.0], dtype=np.float32), "finite"),
        (np.array([np.inf, 0.0], dtype=np.float32), "finite"),
        (np.zeros(3, dtype=np.float32), "shape"),
        (np.zeros((1, 2), dtype=np.float32), "shape"),
        ([0.0], "shape"),
        ("left", "shape"),
        (np.array(["a", "b"]), "finite numbers"),
        # Not cast silently: a complex action would lose its imaginary part, a bool is no torque.
        (np.array([0.5 + 1j, 0.0]), "finite numbers .*got a complex128 array"),
        (np.array([True, False]), "finite numbers .*got a bool array"),
        ([True, False], "got a bool array"),
    ],
)
def test_bad_actions_raise_value_errors(action, message):
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)


def test_finite_actions_beyond_float32_are_clipped_like_any_other():
    # 1e300 is finite (float64) but inf as float32: it is clipped to the torque limit, as 3.0 is.
    far, near = make(actuators=("steer",)).unwrapped, make(actuators=("steer",)).unwrapped
    for env, action in ((far, [-1e300]), (near, np.array([-3.0], dtype=np.float32))):
        env.reset(seed=0, options={"state": [0, 0, 0, 0, 0, 0, 0, 0]})
        env.step(action)
    # Pure steer from rest, upright: ddpsi = 4 tau / (m r^2) with tau = -10 N m, so dpsi = -8 dt.
    assert far._batch.states[7, 0] == near._batch.states[7, 0] == pytest.approx(-4 * 10.0 / 5.0 * 0.02)


def test_an_action_array_of_any_layout_steps_as_its_contiguous_copy():
    # The step's compiled function is looked up once for a C-contiguous float32 action (envs.batch.entry_point): a
    # strided view, a Fortran-ordered or a float64 array must be copied to that layout first, not read as it.
    spin = np.array([0.5, 9.0, -0.25, 9.0], dtype=np.float32)
    actions = [spin[::2], np.asfortranarray(spin[::2]), spin[::2].astype(np.float64), spin[::2].copy()]
    states = []
    for action in actions:
        env = make().unwrapped
        env.reset(seed=0)
        env.step(action)
        states.append(env._batch.states[:, 0].copy())
    for state in states[:-1]:
        np.testing.assert_array_equal(state, states[-1])


@pytest.mark.parametrize("task", sorted(TASKS))
def test_info_has_the_same_keys_at_every_step(task):
    # As Gymnasium's MuJoCo envs: wrappers that stack infos over steps and envs (Tianshou's, TorchRL's) need every
    # key at every step, each a number (TorchRL's info reader takes every key of a vector env as a tensor).
    # "termination" says why an episode terminated, NONE (0) while it has not.
    # 0.8 s episodes; recovery's, 2.4 s: its disk, spinning fast at a large lean, falls under full torques in 1.3 to
    # 2.3 s and stays up passively.
    env = gym.make(rd.TASK_IDS[task], max_episode_steps=120 if task.startswith("recovery") else 40)
    _, info = env.reset(seed=0)
    kinds = {key: type(value) for key, value in info.items()}
    assert (
        type(info["termination"]) is int
        and info["termination"] == rd.Termination.NONE
        and all(info[f"reward_{term}"] == 0.0 for term in env.unwrapped.task.reward_weights)
    )
    fall_lean = env.unwrapped.task.fall_lean
    endings = set()
    for episode in range(6):
        _, info = env.reset(seed=episode)
        assert {key: type(value) for key, value in info.items()} == kinds
        terminated = truncated = False
        while not (terminated or truncated):
            # Every other episode passive: the disk falls (upright, goto) or drifts; full torques: it falls sooner.
            action = np.zeros(2, dtype=np.float32) if episode % 2 else np.ones(2, dtype=np.float32)
            _, _, terminated, truncated, info = env.step(action)
            assert {key: type(value) for key, value in info.items()} == kinds
            # The disk's own lean says whether it fell (full torques may end it otherwise: contact lift-off).
            if abs(info["state"][3]) > fall_lean:
                assert terminated and info["termination"] == rd.Termination.FALLEN
            assert (info["termination"] != rd.Termination.NONE) == terminated
        endings.add("terminated" if terminated else "truncated")
    assert endings == {"terminated", "truncated"}


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"task": "balance"}, "unknown task"),
        ({"actuators": ("spin", "lean")}, "actuators"),
        ({"actuators": "spin"}, "actuators"),
        ({"dt": -0.01}, "dt"),
        ({"dt": float("nan")}, "dt"),
        ({"integrator": "dop853"}, "integrator"),
        ({"substeps": 0}, "substeps"),
        ({"max_spin_torque": 0.0}, "max_spin_torque"),
        ({"params_ranges": {"length": (1, 2)}}, "params_ranges"),
        ({"params_ranges": {"mass": (2, 1)}}, "params_ranges"),
        ({"initial_ranges": {"speed": (0, 1)}}, "initial-state range"),
        ({"task_options": {"target_speed": -1.0}}, "target_speed"),
        ({"task_options": {"reward_weights": {"style": 1.0}}}, "reward term"),
        ({"task": "circle", "task_options": {"radius_range": (0.0, 2.0)}}, "radius_range"),
        ({"render_mode": "ascii"}, "render_mode"),
    ],
)
def test_bad_arguments_raise_at_construction(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rd.RollingDiskEnv(**kwargs)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"state": np.zeros(7)}, "shape"),
        ({"state": [0, 0, 0, np.nan, 0, 0, 0, 0]}, "finite"),
        ({"state": [0, 0, 0, 1.6, 0, 0, 0, 0]}, "domain"),
        ({"state": [0, 0, 0, 0.7, 0, 0, 0, 0]}, "fallen"),
        ({"seed": 3}, "unknown reset option"),
    ],
)
def test_bad_reset_options_raise(options, message):
    with pytest.raises(ValueError, match=message):
        make().reset(seed=0, options=options)


def test_step_before_reset_is_refused():
    with pytest.raises(gym.error.ResetNeeded):
        rd.RollingDiskEnv().step(np.zeros(2, dtype=np.float32))


def test_params_randomization_draws_a_disk_per_episode():
    env = make(params_ranges={"mass": (2.0, 8.0), "radius": (0.5, 1.5)}).unwrapped
    disks = set()
    for seed in range(5):
        env.reset(seed=seed)
        disks.add((env.params.mass, env.params.radius))
        assert 2.0 <= env.params.mass <= 8.0 and 0.5 <= env.params.radius <= 1.5
    assert len(disks) == 5


def test_a_diverging_integrator_terminates_cleanly_with_finite_output():
    # The default task: the integrator, not the task, is under test (and its euler step compiles for the test of
    # the model APIs anyway).
    env = make(integrator="euler", dt=0.5, actuators=())
    env.reset(seed=0, options={"state": [0, 0, 0, 0.3, 0, 40.0, 5.0, 30.0]})
    for _ in range(50):
        observation, reward, terminated, _, info = env.step(np.zeros(0, dtype=np.float32))
        assert np.all(np.isfinite(observation)) and np.isfinite(reward) and np.all(np.isfinite(info["state"]))
        if terminated:
            break
    assert terminated and info["termination"] in (rd.Termination.FALLEN, rd.Termination.OUT_OF_DOMAIN)


def test_pickle_round_trip_keeps_the_episode():
    env = make(task="circle")
    env.reset(seed=4)
    env.step(env.action_space.sample())
    clone = pickle.loads(pickle.dumps(env))
    action = np.array([0.3, -0.2], dtype=np.float32)
    a, b = env.step(action), clone.step(action)
    np.testing.assert_array_equal(a[0], b[0])
    assert a[1] == b[1]
    np.testing.assert_array_equal(a[4]["state"], b[4]["state"])


def test_pickle_after_render_rebuilds_the_renderer():
    env = make(task="circle", render_mode="rgb_array")
    env.reset(seed=4)
    first = env.render()
    clone = pickle.loads(pickle.dumps(env))
    np.testing.assert_array_equal(clone.render(), first)


@pytest.mark.parametrize(("dt", "fps"), [(0.02, 50), (1e-300, 1000), (1e3, 1)])
def test_render_fps_is_one_over_dt_within_what_a_display_can_use(dt, fps):
    assert rd.RollingDiskEnv(dt=dt).metadata["render_fps"] == fps


def test_stable_baselines3_subproc_vec_env_runs():
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    # The children import only what they unpickle: the module-prefixed id makes them import the package (a
    # training script that imports it is preloaded by the forkserver instead).
    vec = make_vec_env(f"rolling_disk_env:{rd.ENV_ID}", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv)
    try:
        vec.reset()
        for _ in range(5):
            observations, rewards, _dones, _infos = vec.step(np.zeros((2, 2), dtype=np.float32))
        assert observations.shape == (2, 4) and np.all(np.isfinite(rewards))
    finally:
        vec.close()


def weighted_means(errors, dt: float, time_constant: float) -> np.ndarray:
    """The bias-corrected exponentially weighted mean of ``errors`` (a row a step, a column an env, or one row) after
    each step, summed afresh with numpy's weights for every step (not the engine's running sums)."""
    errors = np.asarray(errors, dtype=float)
    decay = np.exp(-dt / time_constant)
    means = []
    for step in range(1, len(errors) + 1):
        weights = decay ** np.arange(step - 1, -1, -1.0)
        means.append(np.average(errors[:step], axis=0, weights=weights))
    return np.array(means)


def test_tracking_success_is_the_weighted_mean_error_at_every_step():
    # is_success of circle at every step of an episode (the LQR, then pushed by noisy actions), against the
    # exponentially weighted mean radial error (time constant 2.5 s) recomputed from the states: the start (error above
    # 0.25 m) fails, the rest holds, and the flips come where the recomputed means say.
    from agents.baselines import CircleLQR

    env = gym.make(rd.TASK_IDS["circle"]).unwrapped
    assert env.task.success_time_constant == 2.5
    observation, _ = env.reset(seed=1)
    centre, radius = np.array([env.goal["cx"], env.goal["cy"]]), env.goal["radius"]
    controller, rng = CircleLQR(task="circle"), np.random.default_rng(1)
    errors, successes = [], []
    for step in range(500):
        action = controller.predict(observation)[0] + (rng.normal(0.0, 0.6, 2) if step > 100 else 0.0)
        observation, _, terminated, _, info = env.step(np.clip(action, -1, 1).astype(np.float32))
        assert not terminated
        errors.append(abs(np.hypot(*(info["state"][:2] - centre)) - radius))
        successes.append(info["is_success"])
    means = weighted_means(errors, env.dt, 2.5)
    assert successes == [mean <= 0.25 for mean in means]
    assert not successes[0] and successes[-1]


def test_tracking_success_of_the_vector_env_is_the_weighted_mean_error_of_each_disk():
    # The vector env's is_success, disk by disk, against the weighted means recomputed from its info rows (the same
    # compiled rule as the single env's): the LQR's disks pushed by noise of different sizes, some failing.
    from agents.baselines import CircleLQR

    envs = gym.make_vec(rd.TASK_IDS["circle"], num_envs=6, vectorization_mode="vector_entry_point").unwrapped
    observations, infos = envs.reset(seed=3)
    goals = envs._batch.goals
    centre, radius = goals[1:3, :6].T, goals[0, :6]
    controller, rng = CircleLQR(task="circle"), np.random.default_rng(3)
    scale = np.linspace(0.0, 1.0, 6)[:, None]
    errors, successes = [], []
    for _ in range(300):
        actions = controller.predict(observations)[0] + scale * rng.normal(0.0, 1.0, (6, 2))
        observations, _, terminated, truncated, infos = envs.step(np.clip(actions, -1, 1).astype(np.float32))
        assert not (terminated.any() or truncated.any())
        errors.append(np.abs(np.hypot(*(infos["state"][:, :2] - centre).T) - radius))
        successes.append(infos["is_success"])
    means = weighted_means(errors, envs.config.dt, 2.5)
    assert np.array_equal(np.array(successes), means <= 0.25)
    table = np.array(successes)
    assert (~table[0] & table[-1]).any()  # disks that start too far off their circles, then hold them


def test_tracking_success_keeps_a_fixed_memory_in_an_endless_episode():
    # Without truncation (the single env does not know its limit), the success rule keeps two numbers a disk, lanes
    # rows: nothing the batch carries grows as the episode goes on, and is_success is still the weighted mean.
    from agents.baselines import CircleLQR
    from rolling_disk_env import engine

    env = gym.make(rd.TASK_IDS["circle"], max_episode_steps=None).unwrapped
    observation, _ = env.reset(seed=2)
    carried = [(array.shape, array.nbytes) for array in env._batch.shares()]
    centre, radius = np.array([env.goal["cx"], env.goal["cy"]]), env.goal["radius"]
    controller = CircleLQR(task="circle")
    errors, successes = [], []
    for _ in range(1500):
        observation, _, terminated, _, info = env.step(controller.predict(observation)[0])
        assert not terminated
        errors.append(abs(np.hypot(*(info["state"][:2] - centre)) - radius))
        successes.append(info["is_success"])
    assert [(array.shape, array.nbytes) for array in env._batch.shares()] == carried
    assert env._batch.lanes.shape[0] == engine.LANES and len(engine.BatchArrays._fields) == 3
    means = weighted_means(errors, env.dt, 2.5)
    assert successes == [mean <= 0.25 for mean in means]
    assert all(successes[500:])  # the controller holds the circle
