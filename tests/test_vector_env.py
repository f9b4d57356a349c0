"""The native vector env: Gymnasium's vector API, autoreset, and equality with N single envs."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import rolling_disk_env as rd
from rolling_disk_env import trig
from rolling_disk_env.tasks import TASKS


def _single_envs_like_a_vector(seed, indices, max_episode_steps, **kwargs):
    envs = {i: gym.make(rd.ENV_ID, max_episode_steps=max_episode_steps, **kwargs) for i in indices}
    first = {i: env.reset(seed=seed + i) for i, env in envs.items()}
    return envs, first


RANDOMIZED_DISKS = {"params_ranges": {"mass": (4.0, 6.0), "radius": (0.8, 1.2), "gravity": (9.0, 10.6)}}
LARGE = 2 * trig.TORCH_FROM
"""A batch large enough for the batched path's torch sine and cosine; a few of its envs are compared."""


@pytest.mark.parametrize(
    ("kwargs", "num_envs", "compared"),
    [pytest.param({"task": task}, 6, range(6), id=task) for task in sorted(TASKS)]
    + [pytest.param({"task": task, **RANDOMIZED_DISKS}, 6, range(6), id=f"{task}, random disks") for task in TASKS]
    + [pytest.param({"task": task}, LARGE, (0, 1, LARGE // 2, LARGE - 1), id=f"{task}, N = {LARGE}") for task in TASKS],
)
def test_vector_env_equals_single_envs_with_next_step_autoreset(kwargs, num_envs, compared):
    steps, limit = 160, 60
    vector = gym.make_vec(
        rd.ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point", max_episode_steps=limit, **kwargs
    )
    assert vector.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    observations, infos = vector.reset(seed=11)
    singles, first = _single_envs_like_a_vector(11, compared, limit, **kwargs)
    for i, (observation, info) in first.items():
        np.testing.assert_allclose(observations[i], observation, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(infos["state"][i], info["state"], rtol=0, atol=1e-12)

    actions_rng = np.random.default_rng(0)
    done = np.zeros(num_envs, dtype=bool)
    endings = 0
    for _ in range(steps):
        actions = actions_rng.uniform(-1.2, 1.2, (num_envs, 2)).astype(np.float32)
        observations, rewards, terminated, truncated, infos = vector.step(actions)
        for i, env in singles.items():
            if done[i]:
                expected = (*env.reset(), 0.0, False, False)
                expected = (expected[0], expected[2], expected[3], expected[4], expected[1])
            else:
                expected = env.step(actions[i])
            observation, reward, term, trunc, info = expected
            np.testing.assert_allclose(observations[i], observation, rtol=1e-5, atol=1e-5)
            assert rewards[i] == pytest.approx(reward, abs=1e-7)
            assert (terminated[i], truncated[i]) == (term, trunc)
            np.testing.assert_allclose(infos["state"][i], info["state"], rtol=1e-9, atol=1e-9)
            assert infos["is_success"][i] == info["is_success"]
            if term:
                assert infos["termination"][i] == info["termination"] and infos["_termination"][i]
            endings += done[i]
        done = terminated | truncated
    assert endings >= len(singles)  # autoreset was exercised


def test_vector_spaces_and_types():
    vector = rd.RollingDiskVectorEnv(num_envs=3, max_episode_steps=10)
    observations, _ = vector.reset(seed=0)
    assert observations.shape == (3, 4) and observations.dtype == np.float32
    assert observations in vector.observation_space
    assert vector.action_space.shape == (3, 2)
    observations, rewards, terminated, truncated, infos = vector.step(vector.action_space.sample())
    assert rewards.dtype == np.float64 and terminated.dtype == bool and truncated.dtype == bool
    assert infos["state"].shape == (3, 8) and infos["contact_force"].shape == (3, 2)
    np.testing.assert_allclose(infos["energy"], rd.energy(infos["state"]))


def test_vector_reset_takes_exact_states_and_seed_lists():
    vector = rd.RollingDiskVectorEnv(num_envs=2, task="circle")
    states = np.array([[1, 2, 0, 0.1, 0, 2, 0, 0], [0, 0, 1, -0.2, 1, 3, 0, 0.5]], dtype=float)
    _, infos = vector.reset(seed=[5, 9], options={"state": states})
    np.testing.assert_array_equal(infos["state"], states)
    with pytest.raises(ValueError, match="shape"):
        vector.reset(options={"state": states[0]})
    with pytest.raises(ValueError, match="seed"):
        vector.reset(seed=[1, 2, 3])


@pytest.mark.parametrize(
    ("actions", "message"),
    [
        (np.full((2, 2), np.nan, dtype=np.float32), "finite"),
        (np.zeros((2, 3), dtype=np.float32), "shape"),
        (np.zeros(2, dtype=np.float32), "shape"),
    ],
)
def test_vector_bad_actions_raise(actions, message):
    vector = rd.RollingDiskVectorEnv(num_envs=2)
    vector.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        vector.step(actions)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"num_envs": 0}, "num_envs"), ({"max_episode_steps": 0}, "max_episode_steps"), ({"task": "x"}, "task")],
)
def test_vector_bad_arguments_raise(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rd.RollingDiskVectorEnv(**{"num_envs": 2, **kwargs})
