"""Task ice: goto under Coulomb's contact at mu = 0.1 by default, no other contact; its slip observation and grip term
against the contact point's velocity rebuilt with numpy (tests/reference.py); the friction coefficient drawn per
episode where params_ranges asks."""

import math

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.tasks import GotoTask, IceTask
from tests import reference

PARAMS = rd.DiskParams()


def make(**kwargs):
    return gym.make(rd.TASK_IDS["ice"], **kwargs)


def test_the_task_runs_under_coulombs_contact_at_its_friction():
    env = make()
    assert env.unwrapped.config.contact == "coulomb" and env.unwrapped.config.friction_coefficient == 0.1
    assert make(friction_coefficient=0.05).unwrapped.config.friction_coefficient == 0.05
    with pytest.raises(ValueError, match="task 'ice' runs under contact='coulomb', got contact='rolling'"):
        make(contact="rolling")


def test_the_slip_observed_and_the_grip_term_are_the_contact_points_velocity():
    # Full torques on ice: the contact slides. The slip in the disk's frame, rebuilt from the 10-state with numpy
    # (the contact point's velocity c' + omega x (p - c)).
    env = make(max_episode_steps=100)
    env.reset(seed=3)
    slid = 0
    for step in range(100):
        action = np.array([1.0, math.copysign(1.0, math.sin(step / 8))], np.float32)
        observation, _, terminated, truncated, info = env.step(action)
        x = info["state"]
        velocity = reference.contact_point_velocity(x, PARAMS)[:2]
        psi = x[4]
        forward = velocity @ [math.sin(psi), -math.cos(psi)]
        lateral = velocity @ [math.cos(psi), math.sin(psi)]
        np.testing.assert_allclose(observation[7:], np.float32([forward, lateral]), rtol=1e-5, atol=1e-6)
        grip = -min((forward**2 + lateral**2) / 0.1**2, 1.0)
        assert info["reward_grip"] == pytest.approx(grip, abs=1e-9)
        slid += info["sliding"]
        if terminated or truncated:
            break
    assert slid > 0


def test_its_observation_and_terms_extend_gotos():
    assert IceTask.observation_names[:7] == GotoTask.observation_names
    assert list(IceTask.default_reward_weights)[:-1] == list(GotoTask.default_reward_weights)


def test_the_friction_coefficient_is_drawn_per_episode_and_reported():
    env = rd.RollingDiskVectorEnv(num_envs=64, task="ice", params_ranges={"friction_coefficient": (0.05, 0.2)})
    _, info = env.reset(seed=0)
    mu = info["friction_coefficient"]
    assert mu.shape == (64,) and np.all((0.05 <= mu) & (mu < 0.2)) and np.ptp(mu) > 0.1
    _, info_again = rd.RollingDiskVectorEnv(
        num_envs=64, task="ice", params_ranges={"friction_coefficient": (0.05, 0.2)}
    ).reset(seed=0)
    np.testing.assert_array_equal(info_again["friction_coefficient"], mu)
    # Each disk slides under its own coefficient: where it slides, |F| = mu N with its mu.
    for _ in range(30):
        actions = np.tile(np.array([[1.0, 1.0]], np.float32), (64, 1))
        _, _, _, _, info = env.step(actions)
        sliding = info["sliding"] & (info["normal_force"] > 0)  # (a disk whose normal force vanished lifted off)
        force = np.hypot(*info["contact_force"].T)
        np.testing.assert_allclose(
            force[sliding], info["friction_coefficient"][sliding] * info["normal_force"][sliding], rtol=1e-9
        )
