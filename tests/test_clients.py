"""The env in the RL libraries its users reach for first, as their own docs use them: TorchRL (``GymEnv`` by id,
single and batched, and ``GymWrapper`` over the native vector env), Tianshou (PPO over ``DummyVectorEnv``) and SBX
(SB3's PPO in JAX, on the native SB3 adapter).

Each test skips where its library is not installed (the main test venv has none of them); ``.ci/run`` runs this file
in a venv that has them all and fails if anything skipped there.
"""

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import rolling_disk_env as rd

ALL_IDS = [rd.ENV_ID, *rd.TASK_IDS.values()]


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_torchrl_gym_env_builds_every_id_single_and_batched(env_id):
    pytest.importorskip("torchrl")
    from torchrl.envs import GymEnv
    from torchrl.envs.utils import check_env_specs

    # GymEnv passes frameskip= first and retries without it only on Python's own TypeError wording.
    env = GymEnv(env_id)
    check_env_specs(env)
    rollout = env.rollout(30)
    assert rollout["next", "observation"].shape == (30, *env.observation_spec["observation"].shape)
    env.close()
    # Gymnasium's AsyncVectorEnv of gym.make(env_id), in processes that TorchRL starts by spawn: they import what
    # the main module imports (a user's script imports rolling_disk_env, pytest does not) and what an id names.
    batched = GymEnv(f"rolling_disk_env:{env_id}", num_envs=2)
    try:
        check_env_specs(batched)
        assert batched.rollout(5)["next", "reward"].shape == (2, 5, 1)
    finally:
        batched.close()


def test_torchrl_gym_env_batches_a_plain_id_from_a_user_script(tmp_path):
    pytest.importorskip("torchrl")
    script = tmp_path / "user_script.py"
    script.write_text(
        "import rolling_disk_env  # registers the ids, in the spawned workers too (they import this module)\n"
        "from torchrl.envs import GymEnv\n"
        "from torchrl.envs.utils import check_env_specs\n"
        "if __name__ == '__main__':\n"
        "    env = GymEnv('RollingDiskCircle-v0', num_envs=4)\n"
        "    check_env_specs(env)\n"
        "    print(tuple(env.rollout(3)['next', 'reward'].shape))\n"
        "    env.close()\n"
    )
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    output = subprocess.check_output([sys.executable, str(script)], cwd=tmp_path, env=env, text=True, timeout=600)
    assert output.strip().splitlines()[-1] == "(4, 3, 1)"


def test_torchrl_reports_an_unknown_keyword_argument_clearly():
    pytest.importorskip("torchrl")
    from torchrl.envs import GymEnv

    with pytest.raises(TypeError, match=r"unexpected keyword argument 'speed'.*'task_options'"):
        GymEnv(rd.ENV_ID, speed=2.0)


def test_torchrl_gym_wrapper_steps_the_native_vector_env():
    pytest.importorskip("torchrl")
    from torchrl.envs import GymWrapper
    from torchrl.envs.utils import check_env_specs

    native = gym.make_vec(
        rd.TASK_IDS["circle"],
        num_envs=4,
        vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP,
    )
    env = GymWrapper(native)
    check_env_specs(env)
    rollout = env.rollout(600, break_when_any_done=False)  # past the 500-step truncation: every disk resets
    assert rollout["next", "reward"].shape == (4, 600, 1) and rollout["next", "done"].any(dim=1).all()
    assert rollout["next", "termination"].shape == (4, 600)  # an info key, read as a tensor
    env.close()


@pytest.mark.parametrize("task", sorted(rd.TASK_IDS))
def test_tianshou_ppo_trains_an_epoch_on_every_task(task):
    pytest.importorskip("tianshou")
    import torch
    from tianshou.algorithm import PPO
    from tianshou.algorithm.modelfree.reinforce import ProbabilisticActorPolicy
    from tianshou.algorithm.optim import AdamOptimizerFactory
    from tianshou.data import Collector, CollectStats, VectorReplayBuffer
    from tianshou.env import DummyVectorEnv
    from tianshou.trainer import OnPolicyTrainerParams
    from tianshou.utils.net.common import Net
    from tianshou.utils.net.continuous import ContinuousActorProbabilistic, ContinuousCritic

    torch.manual_seed(0)
    env_id = rd.TASK_IDS[task]
    envs = DummyVectorEnv([lambda: gym.make(env_id) for _ in range(4)])  # unchanged: no info wrapper
    envs.seed(0)
    space = gym.make(env_id)
    shape = space.observation_space.shape
    actor = ContinuousActorProbabilistic(
        preprocess_net=Net(state_shape=shape, hidden_sizes=[32]), action_shape=space.action_space.shape, unbounded=True
    )
    critic = ContinuousCritic(preprocess_net=Net(state_shape=shape, hidden_sizes=[32]))

    def normal(loc_scale):
        loc, scale = loc_scale
        return torch.distributions.Independent(torch.distributions.Normal(loc, scale), 1)

    # The action space is [-1, 1] already: clipped, not rescaled.
    policy = ProbabilisticActorPolicy(
        actor=actor, dist_fn=normal, action_space=space.action_space, action_scaling=False
    )
    algorithm = PPO(policy=policy, critic=critic, optim=AdamOptimizerFactory(lr=3e-4))
    collector = Collector[CollectStats](algorithm, envs, VectorReplayBuffer(2048, len(envs)), exploration_noise=True)
    result = algorithm.run_training(
        OnPolicyTrainerParams(
            training_collector=collector,
            max_epochs=1,
            epoch_num_steps=2048,
            collection_step_num_env_steps=1024,
            batch_size=256,
            update_step_num_repetitions=1,
            show_progress=False,
        )
    )
    assert result.timing.total_time > 0 and collector.collect_step >= 2
    # The on-policy trainer empties the buffer after each update: collect once more to look at what it stacks.
    collector.reset()
    collector.collect(n_step=2048)
    infos = collector.buffer.info[: len(collector.buffer)]
    assert infos["termination"].dtype == np.int64  # every step had the key: no None filled in
    terminated = collector.buffer.terminated[: len(collector.buffer)]
    assert terminated.any()  # episodes ended on the way: their infos were stacked with the others
    np.testing.assert_array_equal(infos["termination"] != rd.Termination.NONE, terminated)
    assert np.all(np.isfinite(infos["reward_effort"]))


def test_sbx_ppo_learns_a_few_thousand_steps_on_the_native_vec_env():
    pytest.importorskip("sbx")
    from sbx import PPO

    env = rd.sb3.make_vec_env(rd.TASK_IDS["upright"], n_envs=4, seed=0)
    model = PPO("MlpPolicy", env, n_steps=256, batch_size=256, n_epochs=2, seed=0)
    model.learn(4096)
    assert model.num_timesteps == 4096
    action, _ = model.predict(env.reset(), deterministic=True)
    assert action.shape == (4, 2) and np.all(np.isfinite(action))
