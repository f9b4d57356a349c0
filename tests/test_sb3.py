"""Stable-Baselines3 on the env: the adapter over the native vector env against DummyVecEnv, and SubprocVecEnv children
started by forkserver and spawn."""

import subprocess
import sys

import numpy as np
import pytest
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

import rolling_disk_env as rd
from rolling_disk_env import sb3
from rolling_disk_env.tasks import TASKS


@pytest.mark.parametrize("task", sorted(TASKS))
def test_native_vec_env_steps_exactly_like_dummy_vec_env(task):
    n_envs, steps = 4, 700  # more than an episode: truncations and falls on the way
    env_id = rd.TASK_IDS[task]
    ours = sb3.make_vec_env(env_id, n_envs=n_envs, seed=3)
    theirs = make_vec_env(env_id, n_envs=n_envs, seed=3, vec_env_cls=DummyVecEnv)
    np.testing.assert_array_equal(ours.reset(), theirs.reset())
    rng = np.random.default_rng(0)
    dones_seen = terminal_seen = 0
    for _ in range(steps):
        actions = rng.uniform(-1.5, 1.5, (n_envs, 2)).astype(np.float32)
        observations, rewards, dones, infos = ours.step(actions)
        expected_observations, expected_rewards, expected_dones, expected_infos = theirs.step(actions)
        np.testing.assert_array_equal(observations, expected_observations)
        assert rewards.dtype == expected_rewards.dtype == np.float32
        np.testing.assert_array_equal(rewards, expected_rewards)
        np.testing.assert_array_equal(dones, expected_dones)
        for info, expected in zip(infos, expected_infos):
            assert info.keys() == expected.keys()
            for key in ("is_success", "TimeLimit.truncated", "termination", "reward_alive", "energy"):
                assert info.get(key) == expected.get(key), key
            np.testing.assert_array_equal(info["state"], expected["state"])
            if "terminal_observation" in expected:
                np.testing.assert_array_equal(info["terminal_observation"], expected["terminal_observation"])
                terminal_seen += 1
            if "episode" in expected:
                # Monitor rounds the return to 6 decimals; VecMonitor sums float32 rewards.
                assert info["episode"]["r"] == pytest.approx(expected["episode"]["r"], abs=1e-4)
                assert info["episode"]["l"] == expected["episode"]["l"]
        dones_seen += dones.sum()
    assert dones_seen == terminal_seen >= n_envs


def test_native_vec_env_trains_ppo():
    from stable_baselines3 import PPO

    env = sb3.make_vec_env(rd.TASK_IDS["upright"], n_envs=4, seed=0)
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(256)
    assert model.num_timesteps == 256


@pytest.mark.parametrize("start_method", ["forkserver", "spawn"])
def test_subproc_vec_env_children_run_the_engine(start_method):
    # The children import only what they unpickle: the module-prefixed id makes them import the package.
    vec = make_vec_env(
        f"rolling_disk_env:{rd.ENV_ID}",
        n_envs=2,
        seed=0,
        vec_env_cls=SubprocVecEnv,
        vec_env_kwargs={"start_method": start_method},
    )
    try:
        first = vec.reset()
        for _ in range(5):
            observations, rewards, _dones, _infos = vec.step(np.zeros((2, 2), dtype=np.float32))
        assert observations.shape == (2, 4) and np.all(np.isfinite(rewards))
    finally:
        vec.close()
    local = make_vec_env(rd.ENV_ID, n_envs=2, seed=0, vec_env_cls=DummyVecEnv)
    np.testing.assert_array_equal(first, local.reset())


def test_native_vec_env_refuses_another_autoreset_mode():
    with pytest.raises(ValueError, match="SAME_STEP"):
        sb3.NativeVecEnv(rd.RollingDiskVectorEnv(num_envs=2))


def test_the_sb3_submodule_is_reachable_after_importing_the_package_and_loads_on_first_use():
    code = (
        "import sys, rolling_disk_env\n"
        "print('stable_baselines3' in sys.modules, 'torch' in sys.modules)\n"
        "print(rolling_disk_env.sb3.make_vec_env.__module__, 'stable_baselines3' in sys.modules)\n"
    )
    lines = subprocess.check_output([sys.executable, "-c", code], text=True).splitlines()
    assert lines == ["False False", "rolling_disk_env.sb3 True"]
