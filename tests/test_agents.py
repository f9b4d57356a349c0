"""Agents: the LQR baselines and a tiny end-to-end training run."""

import numpy as np
import pytest

from agents.baselines import CircleLQR, UprightLQR
from agents.evaluate import PassiveAgent, evaluate, load_agent
from agents.evaluate import main as evaluate_main


def test_upright_lqr_keeps_the_disk_up_where_the_passive_disk_falls():
    lqr = evaluate(UprightLQR(), "lqr", episodes=20, seed=123)
    passive = evaluate(PassiveAgent(), "passive", episodes=20, seed=123)
    assert lqr.successes.all() and lqr.returns.min() > 490
    assert not passive.successes.any()


def test_circle_lqr_holds_the_circle():
    result = evaluate(CircleLQR(task="circle"), "lqr", episodes=20, seed=123, task="circle")
    assert result.successes.mean() >= 0.9


def test_baselines_refuse_the_wrong_task_or_missing_actuators():
    with pytest.raises(ValueError, match="upright"):
        UprightLQR(task="circle")
    with pytest.raises(ValueError, match="actuators"):
        UprightLQR(actuators=("steer",))


def test_tiny_training_run_writes_a_model_that_loads_and_evaluates(tmp_path):
    from stable_baselines3 import PPO

    import train

    results = train.main(["--timesteps", "2048", "--out", str(tmp_path), "--eval-episodes", "4"])
    assert len(results) == 3
    for name in ("model.zip", "vecnormalize.pkl", "config.yml", "command.txt", "results.md"):
        assert (tmp_path / name).exists(), name
    PPO.load(tmp_path / "model.zip", device="cpu")
    assert np.isfinite(evaluate(load_agent(tmp_path / "model.zip"), "tiny", episodes=4).returns).all()
    evaluate_main(["--model", str(tmp_path / "model.zip"), "--episodes", "2", "--out", str(tmp_path / "eval")])
    assert (tmp_path / "eval" / "episode.gif").stat().st_size > 10_000
    assert (tmp_path / "eval" / "episode.png").stat().st_size > 10_000


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_off_policy_algorithms_train_from_their_configs(tmp_path, algo):
    import train

    train.main(["--algo", algo, "--timesteps", "300", "--out", str(tmp_path), "--eval-episodes", "2"])
    assert (tmp_path / "model.zip").exists()
    assert np.isfinite(evaluate(load_agent(tmp_path / "model.zip"), algo, episodes=2).returns).all()


def test_an_exported_policy_loads_and_acts(tmp_path):
    """``agents.evaluate --model policy.pt2`` (``train.py --device``'s export): ``torch.export``'s program of a batch
    of observations to a batch of actions, run on the CPU, for one observation too (the single env's episode)."""
    import torch

    from agents.evaluate import ExportedPolicy, load_agent

    module = torch.nn.Linear(4, 2)
    torch.nn.init.constant_(module.weight, 0.5)
    torch.nn.init.constant_(module.bias, -1.0)
    batch = torch.export.Dim("batch")
    program = torch.export.export(module, (torch.zeros(2, 4),), dynamic_shapes=({0: batch},))
    torch.export.save(program, tmp_path / "policy.pt2")
    agent = load_agent(tmp_path / "policy.pt2")
    assert isinstance(agent, ExportedPolicy)
    np.testing.assert_allclose(agent.predict(np.ones((1, 4), dtype=np.float32))[0], np.full((1, 2), 1.0))
    actions, _ = agent.predict(np.ones((3, 4), dtype=np.float32))
    np.testing.assert_allclose(actions, np.full((3, 2), 1.0))  # 4 * 0.5 - 1
