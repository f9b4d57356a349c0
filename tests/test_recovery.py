"""Task recovery: its starts are the paper's steady circles (the circle condition holds without torque), each with a
positive normal force; the upright count, the success and the reward terms against computations from the states;
its options refused with their message."""

import math

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.tasks import RecoveryTask

PARAMS = rd.DiskParams()
UNPERTURBED = {"dtheta": (0.0, 0.0), "spin_error": (0.0, 0.0), "dpsi_error": (0.0, 0.0)}


def make(**kwargs):
    return gym.make(rd.TASK_IDS["recovery"], **kwargs)


def test_every_start_is_a_perturbed_steady_circle_with_a_positive_normal_force():
    env = rd.RollingDiskVectorEnv(num_envs=2000, task="recovery")
    _, info = env.reset(seed=0)
    states = info["state"]
    theta, dtheta, dpsi = states[:, 3], states[:, 6], states[:, 7]
    low, high = RecoveryTask.default_initial_ranges["lean"]
    assert np.all((low <= np.abs(theta)) & (np.abs(theta) <= high))
    assert np.all(np.sign(theta) == np.sign(dpsi))  # turning into the lean
    assert np.all(np.abs(dtheta) <= 0.5)
    normal = np.array([rd.normal_force(x) for x in states])
    assert normal.min() > 0.5 * PARAMS.mass * PARAMS.gravity
    np.testing.assert_allclose(info["normal_force"], normal, rtol=1e-9)


def test_an_unperturbed_start_rolls_on_its_steady_circle():
    # Zero torque from the steady circle: the lean and the rates stay (a wrong sign or coefficient in the start's
    # circle condition would make the lean move by a tenth of a radian within the second).
    env = make(actuators=(), initial_ranges=UNPERTURBED)
    _, info = env.reset(seed=3)
    start = info["state"]
    for _ in range(50):
        _, _, terminated, _, info = env.step(np.zeros(0, np.float32))
        assert not terminated
    np.testing.assert_allclose(info["state"][[3, 5, 7]], start[[3, 5, 7]], atol=1e-6)
    radius = PARAMS.radius * (start[5] - start[7] * math.sin(start[3])) / start[7]  # the centre path's
    track = np.hypot(*(info["state"][:2] - start[:2]))
    assert track <= 2 * abs(radius) + 1e-6


def test_upright_rolling_held_for_hold_steps_is_a_success_and_each_term_is_the_states():
    # Upright at 2 rad/s (above the self-stabilizing 1.81): zero torque keeps it upright; the count reaches 50.
    env = make(actuators=())
    env.reset(seed=0)
    dphi_target = 2.0 / PARAMS.radius
    observation, info = env.reset(seed=0, options={"state": [0, 0, 0, 0.02, 0, dphi_target, 0.0, 0.1]})
    assert observation[4] == 0.0
    for step in range(1, 51):
        observation, reward, terminated, _, info = env.step(np.zeros(0, np.float32))
        x = info["state"]
        upright = abs(x[3]) <= 0.1 and abs(x[6]) <= 0.3 and abs(x[7]) <= 0.3 and abs(x[5] - dphi_target) <= 0.3
        assert upright
        np.testing.assert_allclose(observation[4], step / 50, rtol=1e-6)
        expected = {
            "upright": -min((x[3] / 1.4) ** 2, 1),
            "rates": -min((x[6] ** 2 + x[7] ** 2) / 4.0, 1),
            "speed": -min(((x[5] - dphi_target) / dphi_target) ** 2, 1),
            "effort": 0.0,
            "recovered": float(step == 50),
            "fallen": 0.0,
        }
        for term, value in expected.items():
            assert info[f"reward_{term}"] == pytest.approx(value, abs=1e-12), term
        weights = RecoveryTask.default_reward_weights
        assert reward == pytest.approx(sum(weights[term] * value for term, value in expected.items()), abs=1e-9)
        assert terminated == (step == 50) and info["is_success"] == (step == 50)
    assert info["termination"] == rd.Termination.REACHED


def test_the_count_starts_over_when_the_disk_leaves_upright_rolling():
    env = make()
    env.reset(seed=0, options={"state": [0, 0, 0, 0.0, 0, 2.0, 0.0, 0.0]})
    env.step(np.zeros(2, np.float32))
    assert env.unwrapped.goal["held"] == 1.0
    env.step(np.array([0.0, 1.0], np.float32))  # full steer: the heading rate leaves the band
    env.step(np.array([0.0, 1.0], np.float32))
    assert abs(env.unwrapped.goal["held"]) == 0.0


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"upright_lean": 1.5}, "upright_lean must be a number in"),
        ({"rate_bound": 0}, "rate_bound must be a finite number > 0"),
        ({"spin_bound": -1}, "spin_bound must be a finite number > 0"),
        ({"hold_steps": 2.5}, "hold_steps must be an integer >= 1"),
        ({"target_speed": math.inf}, "target_speed must be a finite number > 0"),
    ],
)
def test_bad_options_are_refused_with_their_message(options, message):
    with pytest.raises(ValueError, match=message):
        make(task_options=options)


def test_a_start_lean_range_past_the_fall_lean_is_refused():
    with pytest.raises(ValueError, match="'lean'"):
        make(initial_ranges={"lean": (0.5, 1.45)})


def test_the_sparse_task_rewards_the_success_alone_with_recoverys_terms_and_steps():
    dense, sparse = make(), gym.make(rd.TASK_IDS["recovery_sparse"])
    (a, _), (b, _) = dense.reset(seed=5), sparse.reset(seed=5)
    np.testing.assert_array_equal(a, b)
    rng = np.random.default_rng(0)
    for _ in range(100):
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        a, _, end_a, _, info_a = dense.step(action)
        b, reward_b, end_b, _, info_b = sparse.step(action)
        np.testing.assert_array_equal(a, b)
        assert end_a == end_b and np.array_equal(info_a["state"], info_b["state"])
        assert all(info_a[f"reward_{term}"] == info_b[f"reward_{term}"] for term in RecoveryTask.default_reward_weights)
        assert reward_b == info_b["reward_recovered"]
        if end_a:
            break
    sparse.reset(seed=0, options={"state": [0, 0, 0, 0.0, 0, 2.0, 0.0, 0.0]})
    rewards = [sparse.step(np.zeros(2, np.float32))[1] for _ in range(50)]
    assert rewards == [0.0] * 49 + [1.0]
