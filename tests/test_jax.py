"""The JAX env (rolling_disk_env.jax) against the numba engine: the same kernels, the same transitions.

Skipped where JAX is not installed (the main test venv); CI runs this module in a venv of its own with the [jax]
extra (.ci/run), where no test may skip. JAX computes in float64 here (jax_enable_x64), as the engine does.
"""

import importlib.util
import math
import os

import numpy as np
import pytest

if importlib.util.find_spec("jax") is None or importlib.util.find_spec("gymnax") is None:
    pytest.skip("no jax or gymnax (the [jax] extra; CI runs these in a venv of their own)", allow_module_level=True)

import gymnasium as gym
import jax
import jax.numpy as jnp

import rolling_disk_env as rd
from rolling_disk_env import engine
from rolling_disk_env._generated import kernels
from rolling_disk_env.jax import make, traced
from rolling_disk_env.jax.functional import RollingDiskFunctional

jax.config.update("jax_enable_x64", True)

TASKS = tuple(task for task in rd.TASK_IDS if task != "ice")
"""The tasks JAX runs: every one but ice, which runs under Coulomb's contact."""
METHODS = ("euler", "symplectic_euler", "rk4")
FIRST_TASKS = ("upright", "circle", "goto")
"""The tasks whose steps are compared with every integrator and substeps; the others' with RK4 (the integrators are
the same kernels for every task)."""
RTOL = 1e-12
DISK = (5.0, 9.81, 1.0)  # (m, g, r) of the default DiskParams


def numba_env(task: str, **kwargs):
    return gym.make(rd.TASK_IDS[task], **kwargs).unwrapped


def assert_step_agrees(jax_outputs, numba_outputs, rtol=RTOL):
    """A JAX step's (obs, reward, terminated, info) against the Gymnasium env's, key by key."""
    observation, reward, terminated, info = jax_outputs
    expected_observation, expected_reward, expected_terminated, expected_info = numba_outputs
    np.testing.assert_allclose(np.asarray(observation), expected_observation, rtol=1e-6, atol=1e-7)  # float32
    np.testing.assert_allclose(float(reward), expected_reward, rtol=rtol, atol=1e-14)
    assert bool(terminated) == expected_terminated
    assert info.keys() >= expected_info.keys()
    for key, expected in expected_info.items():
        np.testing.assert_allclose(np.asarray(info[key]), expected, rtol=rtol, atol=1e-12, err_msg=key)


def random_states(rng, count):
    """Rolling states within the tasks' range: leans up to 0.6 rad, rates up to 2 rad/s."""
    states = rng.uniform(-1.0, 1.0, (count, 8)) * [3, 3, 3, 0.6, 3, 2, 2, 2]
    return states


def test_lean_jacobians_equal_the_derived_ones():
    """jacfwd of the JAX reading of the lean derivative is SymPy's lean_jacobians, at random states, upright and at
    rest, with no NaN."""
    derivative = traced(kernels.lean_derivative)

    def slope(y, u, m, g, r):
        return jnp.stack(derivative(y, u[0], u[1], m, g, r))

    jacobians = jax.jit(jax.jacfwd(slope, argnums=(0, 1)))
    rng = np.random.default_rng(0)
    states = [*rng.uniform(-1.0, 1.0, (100, 4)) * [1.2, 3, 3, 3], [0.0, 1.0, 0.0, 0.0], [0.0] * 4]
    for y in states:
        u = rng.uniform(-5.0, 5.0, 2)
        m, g, r = rng.uniform(0.5, 2.0, 3) * DISK
        a, b = jacobians(jnp.asarray(y), jnp.asarray(u), m, g, r)
        got = np.concatenate([np.ravel(a), np.ravel(b)])
        expected = np.array(kernels.lean_jacobians.py_func(tuple(y), u[0], u[1], m, g, r))
        assert np.all(np.isfinite(got))
        np.testing.assert_allclose(got, expected, rtol=RTOL, atol=1e-12 * np.abs(expected).max())


def test_steady_circle_newton_iteration_reads_as_the_engines():
    """The JAX reading of engine.steady_circle, a Newton iteration that breaks when it has converged (read as its
    engine.NEWTON_STEPS steps, each holding the solution once converged), gives the engine's steady circles vmapped
    over radii from 0.05 m to 10 km, within 1e-14 (the two libraries' atan), with NaN where neither has one; a loop
    whose body branches has no reading."""
    solve = traced(engine.steady_circle)
    radii = np.concatenate([np.geomspace(0.05, 1e4, 500), np.linspace(3.0, 6.0, 100)])
    got = np.asarray(jax.jit(jax.vmap(lambda radius: jnp.stack(solve(radius, 2.0, 9.81, 1.0))))(radii))
    expected = np.array([engine.steady_circle(radius, 2.0, 9.81, 1.0) for radius in radii])
    assert 0 < np.isnan(expected).sum() < len(radii)
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=0)
    with pytest.raises(NotImplementedError, match="lean_advance_adaptive' has a loop"):
        traced(engine.lean_advance_adaptive)


def rollout_cost(step, x, torques, dt, disk):
    """A cost of a rollout: the lean and the spin rate's error to 1 rad/s, squared, summed over the steps."""
    cost = 0.0
    for tau in torques:
        x = step(x, dt, tau[0], tau[1], *disk)
        cost = cost + x[3] * x[3] + 0.1 * (x[5] - 1.0) * (x[5] - 1.0)
    return cost


def test_rollout_gradient_matches_finite_differences_of_the_engine():
    """jax.grad of a 100-step RK4 rollout's cost w.r.t. the torques and the start state equals central finite
    differences of the numba kernels' rollout to 1e-6, relative to the gradient's largest component (the
    differences' round-off, 1e-16 of the cost over h, is about 1e-10 of it)."""
    step = traced(kernels.state_rk4_step)

    def cost(x0, torques):
        def body(carry, tau):
            x, total = carry
            x = step(tuple(x), 0.02, tau[0], tau[1], *DISK)
            total = total + x[3] * x[3] + 0.1 * (x[5] - 1.0) * (x[5] - 1.0)
            return (jnp.stack(x), total), None

        return jax.lax.scan(body, (x0, 0.0), torques)[0][1]

    rng = np.random.default_rng(1)
    x0 = np.array([0.0, 0.0, 0.3, 0.05, 0.2, 1.0, 0.02, -0.03])
    torques = rng.uniform(-0.5, 0.5, (100, 2))
    grad_x0, grad_torques = jax.jit(jax.grad(cost, argnums=(0, 1)))(jnp.asarray(x0), jnp.asarray(torques))

    def numba_cost(x, tau):
        return rollout_cost(kernels.state_rk4_step, tuple(x), tau, 0.02, DISK)

    h = 1e-5
    scale = max(np.abs(grad_x0).max(), np.abs(grad_torques).max())
    for j in (3, 5, 6, 7):
        plus, minus = x0.copy(), x0.copy()
        plus[j] += h
        minus[j] -= h
        central = (numba_cost(plus, torques) - numba_cost(minus, torques)) / (2 * h)
        np.testing.assert_allclose(float(grad_x0[j]), central, rtol=0, atol=1e-6 * scale)
    for k, j in ((0, 0), (0, 1), (50, 1), (99, 0)):
        plus, minus = torques.copy(), torques.copy()
        plus[k, j] += h
        minus[k, j] -= h
        central = (numba_cost(x0, plus) - numba_cost(x0, minus)) / (2 * h)
        np.testing.assert_allclose(float(grad_torques[k, j]), central, rtol=0, atol=1e-6 * scale)


@pytest.mark.parametrize(
    ("task", "method", "substeps"),
    [
        *(
            pytest.param(task, method, substeps, id=f"{substeps}-{method}-{task}")
            for task in FIRST_TASKS
            for method in METHODS
            for substeps in (1, 3)
        ),
        *(pytest.param(task, "rk4", 1, id=f"1-rk4-{task}") for task in TASKS if task not in FIRST_TASKS),
    ],
)
def test_step_equals_the_engine(task, method, substeps):
    """From the engine's state at each step and the same action (teacher-forced: the state; the success rule's
    running sums come from the previous forced step), the JAX step gives the Gymnasium env's observation, reward,
    termination and info; and left to run on its own for 200 steps (or to the end of the episode), it stays within
    1e-12 of the engine."""
    kwargs = {"integrator": method, "substeps": substeps}
    env, params = make(task, **kwargs)
    step = jax.jit(env.step_env)
    reference = numba_env(task, **kwargs)
    rng = np.random.default_rng(2)
    key = jax.random.PRNGKey(0)
    for seed in range(3):
        _, info = reference.reset(seed=seed)
        goal = np.array(list(reference.goal.values()))
        observation, free = env.start_from(info["state"], goal, params)
        forced = free
        for _ in range(200):
            action = rng.uniform(-1.0, 1.0, 2).astype(np.float32)
            forced = forced.replace(x=jnp.asarray(info["state"]))
            expected = reference.step(action)
            expected = (expected[0], expected[1], expected[2], expected[4])
            observation, forced, reward, terminated, info_jax = step(key, forced, jnp.asarray(action), params)
            assert_step_agrees((observation, reward, terminated, info_jax), expected)
            observation, free, reward, terminated, info_free = step(key, free, jnp.asarray(action), params)
            assert_step_agrees((observation, reward, terminated, info_free), expected)
            info = expected[3]
            if expected[2]:
                break


def test_circle_success_is_the_weighted_mean_radial_error_within_its_bound():
    """circle's is_success, step by step over an episode where it changes (the running sums carried), is the numba
    env's and an independent computation's from the engine's states: not fallen and the exponentially weighted mean
    of |e_r| over the steps so far, sum_n w^(N-n) |e_r(n)| / sum_n w^(N-n) with w = exp(-0.02 s / 2.5 s), at most
    0.25 m (the task's documented rule); the JAX state's sums give that mean to 1e-12, and gymnax's autoreset zeroes
    them. The disk starts 0.4 m inside the circle, tangent to it, and rolls on with no torque: its straight path
    crosses the circle and leaves it, so the mean falls below the bound, then rises above it."""
    decay, bound = math.exp(-0.02 / 2.5), 0.25
    kwargs = {"initial_ranges": {"radial_offset": (-0.4, -0.4), "heading_error": (0.0, 0.0)}}
    env, params = make("circle", **kwargs)
    reference = numba_env("circle", **kwargs)
    _, info = reference.reset(seed=0)
    goal = reference.goal
    _, state = env.start_from(info["state"], np.array(list(goal.values())), params)
    step = jax.jit(env.step_env)
    action = np.zeros(2, np.float32)
    errors, fallen, means, jax_success, numba_success = [], [], [], [], []
    for _ in range(300):
        _, state, _, _, info_jax = step(jax.random.PRNGKey(0), state, jnp.asarray(action), params)
        _, _, terminated, _, info = reference.step(action)
        c1, c2 = info["state"][:2]
        errors.append(abs(math.hypot(c1 - goal["cx"], c2 - goal["cy"]) - goal["radius"]))
        fallen.append(info["termination"] == rd.Termination.FALLEN)
        means.append(float(state.tracking_sum / state.tracking_weight))
        jax_success.append(bool(info_jax["is_success"]))
        numba_success.append(info["is_success"])
        if terminated:
            break
    weights = decay ** np.subtract.outer(np.arange(len(errors)), np.arange(len(errors)))
    weights = np.tril(weights)  # row N: w^(N-n) for the steps n <= N
    expected_means = weights @ np.array(errors) / weights.sum(axis=1)
    expected = (expected_means <= bound) & ~np.array(fallen)
    assert np.count_nonzero(np.diff(expected)) >= 2  # False, then True, then False
    np.testing.assert_array_equal(jax_success, expected)
    np.testing.assert_array_equal(numba_success, expected)
    np.testing.assert_allclose(means, expected_means, rtol=RTOL)
    _, state, _, _, truncated, _ = jax.jit(env.step)(
        jax.random.PRNGKey(1), state, jnp.asarray(action), params.replace(max_steps_in_episode=state.time + 1)
    )
    assert bool(truncated)
    assert float(state.tracking_sum) == float(state.tracking_weight) == 0.0


def test_slipped_where_the_contact_needs_more_friction():
    """With a finite friction_coefficient, a step whose contact needs more ends with SLIPPED, as in the engine."""
    env, params = make("upright", friction_coefficient=0.01)
    reference = numba_env("upright", friction_coefficient=0.01)
    _, info = reference.reset(seed=0)
    _, state = env.start_from(info["state"], np.array(list(reference.goal.values())), params)
    action = np.array([1.0, -1.0], np.float32)
    expected = reference.step(action)
    outputs = env.step_env(jax.random.PRNGKey(0), state, jnp.asarray(action), params)
    assert expected[4]["termination"] == rd.Termination.SLIPPED
    assert_step_agrees((outputs[0], outputs[2], outputs[3], outputs[4]), (*expected[:3], expected[4]))


@pytest.mark.parametrize("task", TASKS)
def test_vmap_and_jit_agree_with_single_steps(task):
    """A step vmapped over 1,024 disks equals 1,024 single steps; jit equals the eager step within 1e-14."""
    env, params = make(task)
    keys = jax.random.split(jax.random.PRNGKey(3), 1024)
    _, states = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    actions = jax.random.uniform(jax.random.PRNGKey(4), (1024, 2), minval=-1.0, maxval=1.0)
    batch = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))(keys, states, actions, params)
    single = jax.jit(env.step_env)
    for i in range(0, 1024, 97):
        state = jax.tree.map(lambda leaf, i=i: leaf[i], states)
        one = single(keys[i], state, actions[i], params)
        for got, expected in zip(jax.tree.leaves(batch), jax.tree.leaves(one)):
            np.testing.assert_allclose(np.asarray(got)[i], np.asarray(expected), rtol=1e-14, atol=1e-14)
    eager = env.step_env(keys[0], jax.tree.map(lambda leaf: leaf[0], states), actions[0], params)
    compiled = single(keys[0], jax.tree.map(lambda leaf: leaf[0], states), actions[0], params)
    for got, expected in zip(jax.tree.leaves(compiled), jax.tree.leaves(eager)):
        np.testing.assert_allclose(np.asarray(got), np.asarray(expected), rtol=1e-14, atol=1e-14)


def test_ice_is_refused_with_its_reason():
    with pytest.raises(ValueError, match="Coulomb"):
        make("ice")


def test_randomized_disks_are_drawn_at_reset_and_step_as_the_engine_given_the_drawn_values():
    """params_ranges in JAX: each reset draws m, g, r within their ranges from its own key (the same key, the same
    disk), reported in info; teacher-forced with a drawn disk, the step is the Gymnasium env's of that disk."""
    ranges = {"mass": (4.0, 6.0), "gravity": (9.0, 10.0), "radius": (0.8, 1.2)}
    env, params = make("goto", params_ranges=ranges)
    keys = jax.random.split(jax.random.PRNGKey(7), 256)
    _, states = jax.vmap(env.reset_env, in_axes=(0, None))(keys, params)
    disks = np.asarray(states.disk)
    for j, (low, high) in enumerate(ranges.values()):
        assert np.all((low <= disks[:, j]) & (disks[:, j] < high)) and np.ptp(disks[:, j]) > 0.8 * (high - low)
    again = np.asarray(jax.vmap(env.reset_env, in_axes=(0, None))(keys, params)[1].disk)
    np.testing.assert_array_equal(again, disks)
    step = jax.jit(env.step_env)
    for i in (0, 100):
        m, g, r = disks[i]
        state = jax.tree.map(lambda leaf, i=i: leaf[i], states)
        reference = numba_env("goto", params=rd.DiskParams(mass=m, gravity=g, radius=r))
        reference.reset(seed=0, options={"state": np.asarray(state.x)})
        reference._batch.goals[:, 0] = np.asarray(state.goal)
        action = np.array([0.3, -0.5], np.float32)
        expected = reference.step(action)
        observation, _, reward, terminated, info = step(keys[i], state, jnp.asarray(action), params)
        assert_step_agrees(
            (observation, reward, terminated, info), (expected[0], expected[1], expected[2], expected[4])
        )
        assert float(info["mass"]) == m and float(info["radius"]) == r


def test_truncation_keeps_the_final_observation():
    """At max_steps_in_episode the step truncates, resets, and hands the last observation in
    info["final_observation"] (gymnax 1.0's convention)."""
    env, params = make("upright", initial_ranges={"dphi": (3.0, 3.0), "theta": (0.0, 0.0), "dtheta": (0.0, 0.0)})
    params = params.replace(max_steps_in_episode=5)
    key = jax.random.PRNGKey(5)
    observation, state = env.reset(key, params)
    step = jax.jit(env.step)
    for t in range(5):
        key, now = jax.random.split(key)
        observation, state, _, terminated, truncated, info = step(now, state, jnp.zeros(2), params)
        assert not bool(terminated)
        assert bool(truncated) == (t == 4)
    assert int(state.time) == 0
    final = np.asarray(info["final_observation"])
    assert not np.array_equal(final, np.asarray(observation))
    np.testing.assert_allclose(final[2], 3.0 - 1.0, rtol=1e-2)  # still spinning at 3 rad/s, target 1 rad/s


def test_vmap_over_disks_of_different_sizes():
    """vmap over EnvParams: each disk of a batch of radii steps as a single env of that disk."""
    env, params = make("upright")
    radii = jnp.array([0.5, 1.0, 2.0])
    batch = jax.vmap(lambda r: params.replace(radius=r))(radii)
    x0 = jnp.array([0.0, 0.0, 0.0, 0.1, 0.0, 1.0, 0.0, 0.0])
    step = jax.vmap(lambda p: env.step_env(jax.random.PRNGKey(0), env.start_from(x0, [1.0], p)[1], jnp.ones(2), p))
    states = step(batch)[1].x
    for i, r in enumerate((0.5, 1.0, 2.0)):
        reference = numba_env("upright", params=rd.DiskParams(radius=r))
        reference.reset(seed=0, options={"state": np.asarray(x0)})
        np.testing.assert_allclose(np.asarray(states[i]), reference.step(np.ones(2, np.float32))[4]["state"], rtol=RTOL)


@pytest.mark.parametrize("task", TASKS)
def test_gymnasium_functional_env_steps_as_the_gymnax_env(task):
    """gym.make("RollingDiskJax-v0"): Gymnasium's FunctionalJaxEnv over the gymnax step, its keys split as Gymnasium
    splits them: the same observations, rewards, flags and info (jitted against not: within 1e-14), with
    RollingDisk-v0's info keys."""
    env = gym.make(rd.JAX_ID, task=task)
    gymnax_env, params = make(task)
    observation, info = env.reset(seed=3)
    key = jax.random.PRNGKey(3)
    now, key = jax.random.split(key)
    expected, state = gymnax_env.reset_env(now, params)
    # float32, jitted against not: within its rounding (XLA may fuse the products of a value that cancels to 1e-16).
    np.testing.assert_allclose(np.asarray(observation), np.asarray(expected), rtol=1e-6, atol=1e-7)
    assert info == {}
    reference = numba_env(task)
    reference.reset(seed=0)
    numba_keys = set(reference.step(np.zeros(2, np.float32))[4])
    rng = np.random.default_rng(4)
    for _ in range(40):
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        observation, reward, terminated, truncated, info = env.step(action)
        now, key = jax.random.split(key)
        expected, state, expected_reward, expected_terminated, expected_info = gymnax_env.step_env(
            now, state, jnp.asarray(action), params
        )
        np.testing.assert_allclose(np.asarray(observation), np.asarray(expected), rtol=1e-6, atol=1e-7)  # float32
        np.testing.assert_allclose(reward, float(expected_reward), rtol=1e-14, atol=1e-15)
        assert terminated == bool(expected_terminated) and not truncated
        assert set(info) == numba_keys
        for name, value in info.items():
            expected_value = np.asarray(expected_info[name])
            np.testing.assert_allclose(np.asarray(value), expected_value, rtol=1e-14, atol=1e-14, err_msg=name)
            assert np.asarray(value).dtype.kind == expected_value.dtype.kind, name
        if terminated:
            break


def test_gymnasium_functional_vector_env_truncates_and_resets():
    """gym.make_vec("RollingDiskJax-v0", vectorization_mode="vector_entry_point"): vmapped disks that truncate at
    max_episode_steps and start again at the next step; each disk's step is the single disk's."""
    envs = gym.make_vec(rd.JAX_ID, 8, vectorization_mode="vector_entry_point", task="goto", max_episode_steps=5)
    single = RollingDiskFunctional("goto")
    observation, _ = envs.reset(seed=0)
    assert observation.shape == (8, *envs.single_observation_space.shape)
    for t in range(6):
        actions = np.full((8, 2), 0.3, np.float32)
        before = envs.unwrapped.state
        observation, reward, terminated, truncated, info = envs.step(actions)
        if t < 5:
            assert np.all(np.asarray(truncated) == (t == 4)) and not np.any(np.asarray(terminated))
            after = envs.unwrapped.state
            for i in (0, 7):  # each disk as one (jax.vmap against the single function, unjitted)
                stepped = single.transition(before[i], jnp.asarray(actions[i]), None)
                np.testing.assert_allclose(np.asarray(after[i]), np.asarray(stepped), rtol=1e-14, atol=1e-15)
        else:  # the step after the truncation starts new episodes (next-step autoreset)
            assert not np.any(np.asarray(truncated)) and not np.any(np.asarray(terminated))
            assert np.all(np.asarray(envs.unwrapped.state)[:, single.layout["time"]] == 0)
        assert np.asarray(info["state"]).shape == (8, 8) and np.asarray(reward).shape == (8,)


def test_float32_where_x64_is_off():
    """With jax_enable_x64 off, the env computes in float32, within float32's round-off of the engine."""
    reference = numba_env("upright")
    _, info = reference.reset(seed=0)
    with jax.enable_x64(False):
        env, params = make("upright")
        _, state = env.start_from(info["state"], [1.0], params)
        assert state.x.dtype == jnp.float32
        outputs = jax.jit(env.step_env)(jax.random.PRNGKey(0), state, jnp.full(2, 0.5), params)
    expected = reference.step(np.full(2, 0.5, np.float32))[4]["state"]
    np.testing.assert_allclose(np.asarray(outputs[4]["state"]), expected, rtol=1e-5, atol=1e-6)


def test_train_py_jax_writes_the_run_folder(tmp_path):
    """``train.py --jax``: rejax's PPO on the gymnax env (a short run) writes the run folder and the results table
    of the other trainers, evaluated on the Gymnasium env."""
    from jax.experimental.compilation_cache import compilation_cache

    import train

    out, cache = tmp_path / "run", tmp_path / "xla"
    compilation_cache.reset_cache()
    jax.config.update("jax_compilation_cache_dir", str(cache))  # the training keeps JAX's setting where one is made
    try:
        arguments = ["--jax", "--timesteps", "2048", "--n-envs", "4", "--eval-episodes", "3", "--out", str(out)]
        results = train.main(arguments)
    finally:
        jax.config.update("jax_compilation_cache_dir", None)
        compilation_cache.reset_cache()
    assert [result.name.split(" ")[0] for result in results] == ["PPO", "passive", "baseline:"]
    for name in ("config.yml", "command.txt", "algo.txt", "results.md", "timings.md", "policy.msgpack"):
        assert (out / name).is_file(), name
    assert "PPO (rejax" in (out / "results.md").read_text()
    assert any(cache.iterdir()), "the compiled training is not in XLA's persistent cache"


def test_the_manuals_examples_run(tmp_path):
    """The ```py blocks of docs/jax.md (not run by tests/test_docs.py, whose venvs have no gymnax) run as written;
    the gradient example leans the disk to its target and draws its plot."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    blocks = re.findall(r"^```py\n(.*?)^```$", (root / "docs" / "jax.md").read_text(), re.MULTILINE | re.DOTALL)
    assert len(blocks) == 3
    outputs = []
    for code in blocks:
        script = tmp_path / "snippet.py"
        script.write_text(code)
        result = subprocess.run(
            [sys.executable, str(script)],
            cwd=tmp_path,
            env={**os.environ, "PYTHONPATH": str(root), "MPLBACKEND": "Agg"},
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        outputs.append(result.stdout)
    assert outputs[1].split() == ["(256,", "7)", "[]"]  # the Gymnasium way
    final_lean = float(re.search(r"final lean ([\d.]+) rad", outputs[2]).group(1))
    assert abs(final_lean - 0.2) < 0.01
    assert (tmp_path / "jax_gradient.png").stat().st_size > 0
