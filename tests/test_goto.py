"""Task goto: the checkers, reaching and falling on constructed states, the reward terms against the kinematics, the
baseline against the passive disk, and the single env against the vector env."""

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import rolling_disk_env as rd
from agents.baselines import GotoLQR
from agents.evaluate import PassiveAgent, evaluate
from rolling_disk_env import codegen
from rolling_disk_env.tasks import GotoTask

ACTUATOR_SETS = [(), ("spin",), ("steer",), ("spin", "steer")]
TERMS = tuple(GotoTask.default_reward_weights)


def make(**kwargs):
    return gym.make(rd.TASK_IDS["goto"], **kwargs)


def started(seed=0, state=None):
    """An env reset with ``seed`` (and the initial ``state``), and its episode's target (x, y) in m."""
    env = make()
    env.reset(seed=seed)
    target = env.unwrapped.goal["x"], env.unwrapped.goal["y"]
    if state is not None:
        env.reset(seed=seed, options={"state": state})
    return env, target


@pytest.mark.parametrize("actuators", ACTUATOR_SETS)
def test_gymnasium_checker_passes_with_warnings_as_errors(actuators):
    env = make(actuators=actuators)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("actuators", ACTUATOR_SETS)
def test_stable_baselines3_checker_passes_with_warnings_as_errors(actuators):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make(actuators=actuators)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_check_env(env.unwrapped, warn=True)


def test_generated_steps_are_current():
    committed = (codegen.GENERATED_DIR / "goto.py").read_text()
    assert committed == codegen.generate_steps(GotoTask), (
        "_generated/goto.py is stale: run python -m rolling_disk_env.codegen"
    )


def test_the_target_lies_at_the_drawn_distance_and_bearing():
    ranges = {"distance_range": (5.0, 5.0), "bearing_range": (math.pi / 2, math.pi / 2)}
    env = make(task_options=ranges, initial_ranges={"psi": (0.3, 0.3)})
    observation, info = env.reset(seed=0)
    goal = env.unwrapped.goal
    # Rolling direction (sin psi, -cos psi); a quarter turn to the left of it is (cos psi, sin psi).
    np.testing.assert_allclose([goal["x"], goal["y"]], [5 * math.cos(0.3), 5 * math.sin(0.3)], atol=1e-12)
    np.testing.assert_allclose(observation[:3], [5.0, 1.0, 0.0], atol=1e-6)
    assert not info["is_success"]


@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.2, -0.1)])
def test_a_centre_placed_at_the_target_ends_the_episode_as_a_success(offset):
    env, (x, y) = started(seed=3)
    env.reset(seed=3, options={"state": [x + offset[0], y + offset[1], 0.0, 0.0, 0.5, 0.0, 0.0, 0.0]})
    _, reward, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
    assert terminated and not truncated
    assert info["termination"] == rd.Termination.REACHED and info["is_success"]
    assert info["reward_reached"] == 1.0 and info["reward_fallen"] == 0.0
    assert reward >= 100.0 - 1.0  # the bonus, at most one unit of progress and lean lost


def test_a_centre_just_outside_the_reach_radius_goes_on():
    env, (x, y) = started(seed=3)
    env.reset(seed=3, options={"state": [x + 0.3, y, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]})  # at rest: the centre stays
    _, _, terminated, _, info = env.step(np.zeros(2, dtype=np.float32))
    assert not terminated and not info["is_success"] and info["reward_reached"] == 0.0


@pytest.mark.parametrize(
    ("theta", "dtheta", "reason"),
    [(0.79, 1.0, "fallen"), (0.3, 4.0, "lifted_off")],  # lift-off: r cos(theta) dtheta^2 > g, the normal force < 0
)
def test_a_falling_or_lifting_disk_fails_even_at_the_target(theta, dtheta, reason):
    env, (x, y) = started(seed=3)
    env.reset(seed=3, options={"state": [x, y, 0.0, theta, 0.0, 0.0, dtheta, 0.0]})
    _, _, terminated, _, info = env.step(np.zeros(2, dtype=np.float32))
    assert terminated and rd.Termination(info["termination"]).name == reason.upper() and not info["is_success"]
    assert info["reward_fallen"] == -1.0 and info["reward_reached"] == 0.0


def test_a_disk_that_falls_far_from_the_target_fails():
    env, _ = started(seed=4, state=[0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0])
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
    assert terminated and info["termination"] == rd.Termination.FALLEN and not info["is_success"]


def test_reward_terms_are_bounded_and_weighted_under_random_actions():
    num_envs = 64
    vector = rd.RollingDiskVectorEnv(num_envs=num_envs, max_episode_steps=rd.MAX_EPISODE_STEPS, task="goto")
    vector.reset(seed=0)
    rng = np.random.default_rng(0)
    weights = np.array(list(GotoTask.default_reward_weights.values()))
    seen = {term: set() for term in ("reached", "fallen")}
    for _ in range(600):
        _, rewards, terminated, _, infos = vector.step(rng.uniform(-1.5, 1.5, (num_envs, 2)).astype(np.float32))
        terms = np.stack([infos[f"reward_{term}"] for term in TERMS], axis=1)
        assert np.all(np.abs(terms) <= 1.0)
        np.testing.assert_allclose(rewards, terms @ weights, rtol=1e-12, atol=1e-9)
        for term in seen:
            seen[term] |= set(np.unique(infos[f"reward_{term}"][terminated]).tolist())
    assert -1.0 in seen["fallen"]  # random torques make disks fall


def test_progress_is_the_rate_at_which_the_distance_shrinks():
    # An independent computation: the finite difference of the distance to the target, from the states.
    env, (x, y) = started(seed=1)
    _, info = env.reset(seed=1)
    rng = np.random.default_rng(1)
    for _ in range(100):
        before = math.dist(info["state"][:2], (x, y))
        _, _, terminated, _, info = env.step(rng.uniform(-0.3, 0.3, 2).astype(np.float32))
        if terminated:
            break
        after = math.dist(info["state"][:2], (x, y))
        speed = env.unwrapped.task.cruise_speed
        if abs(info["reward_progress"]) < 1.0:
            assert info["reward_progress"] == pytest.approx(-(after - before) / 0.02 / speed, abs=0.03)


@pytest.mark.xdist_group("contact steps")  # goto's contact step: compiled in test_contact_env's worker
@pytest.mark.parametrize(
    ("contact", "mu"),
    [("sliding", 0.0), ("coulomb", 0.05)],
    ids=["frozen lake", "coulomb mu=0.05, slipping"],
)
def test_progress_follows_a_sliding_centre_off_the_rolling_constraint(contact, mu):
    # A vertical disk that does not spin, its centre sliding towards the target at 1.5 m/s: the rolling constraint would
    # say it stands still. The same independent computation as above: the finite difference of the distance.
    env = make(contact=contact, friction_coefficient=mu)
    env.reset(seed=5)
    x, y = env.unwrapped.goal["x"], env.unwrapped.goal["y"]
    c1, c2 = x - 4.0, y - 3.0  # 5 m away, the target along (0.8, 0.6)
    _, info = env.reset(seed=5, options={"state": [c1, c2, 0.0, 0.0, 0.0, 1.2, 0.9, 0.0, 0.0, 0.0]})
    speed = env.unwrapped.task.cruise_speed
    progress = []
    for _ in range(20):
        before = math.dist(info["state"][:2], (x, y))
        _, _, terminated, _, info = env.step(np.zeros(2, dtype=np.float32))
        assert not terminated and info["sliding"]
        after = math.dist(info["state"][:2], (x, y))
        assert info["reward_progress"] == pytest.approx(-(after - before) / 0.02 / speed, abs=0.01)
        progress.append(info["reward_progress"])
    # Newton's law for the centre: on the frozen lake no horizontal force, it glides on at 1.5 m/s; kinetic friction,
    # mu N with N = m g for a vertical disk, slows it by at most mu g along the way to the target.
    assert progress[0] == pytest.approx(1.5 / speed, abs=0.01)
    slowing = (progress[0] - progress[-1]) * speed / (19 * 0.02)
    assert (slowing == pytest.approx(0.0, abs=1e-9)) if mu == 0.0 else (0.5 * mu * 9.81 < slowing <= mu * 9.81)


def test_the_baseline_beats_the_passive_disk_on_10_seeds():
    baseline = evaluate(GotoLQR(task="goto"), "baseline", episodes=10, seed=123, task="goto")
    passive = evaluate(PassiveAgent(), "passive", episodes=10, seed=123, task="goto")
    assert baseline.successes.sum() >= 8 and not passive.successes.any()
    assert baseline.returns.mean() > passive.returns.mean() + 200


def test_single_and_vector_envs_agree_to_the_last_bit_through_reached_episodes():
    num_envs, seed = 4, 7
    baseline = GotoLQR(task="goto")
    vector = rd.RollingDiskVectorEnv(num_envs=num_envs, max_episode_steps=rd.MAX_EPISODE_STEPS, task="goto")
    singles = [make() for _ in range(num_envs)]
    observations, _ = vector.reset(seed=seed)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(env.reset(seed=seed + i)[0], observations[i])
    done = np.zeros(num_envs, dtype=bool)
    reached = 0
    for _ in range(800):
        actions, _ = baseline.predict(observations)
        observations, rewards, terminated, truncated, infos = vector.step(actions)
        for i, env in enumerate(singles):
            if done[i]:
                observation, info = env.reset()
                reward, term, trunc = 0.0, False, False
            else:
                observation, reward, term, trunc, info = env.step(actions[i])
            np.testing.assert_array_equal(observations[i], observation)
            assert (rewards[i], terminated[i], truncated[i]) == (reward, term, trunc)
            np.testing.assert_array_equal(infos["state"][i], info["state"])
            assert infos["is_success"][i] == info["is_success"]
            reached += term and info["termination"] == rd.Termination.REACHED
        done = terminated | truncated
    assert reached >= num_envs  # every env reached a target, and the autoreset started another episode


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"cruise_speed": 0.0}, "cruise_speed"),
        ({"reach_radius": -1.0}, "reach_radius"),
        ({"distance_range": (0.1, 3.0)}, "distance_range"),
        ({"distance_range": (4.0, 3.0)}, "distance_range"),
        ({"bearing_range": (0.0, math.inf)}, "bearing_range"),
        ({"reward_weights": {"alive": 1.0}}, "unknown reward term"),
    ],
)
def test_bad_task_options_raise(options, message):
    with pytest.raises(ValueError, match=message):
        make(task_options=options)
