"""Agents: the LQR baselines, the linearization they use, and a tiny end-to-end training run."""

import numpy as np
import pytest

import rolling_disk_env as rd
from agents.baselines import CircleLQR, UprightLQR, lean_linearization
from agents.evaluate import PassiveAgent, evaluate, load_agent
from agents.evaluate import main as evaluate_main


@pytest.mark.parametrize("lean_state", [(0.0, 1.0, 0.0, 0.0), (0.2, 2.1, 0.3, 0.5), (-0.6, -1.0, 1.2, -2.0)])
def test_lqr_linearization_matches_finite_differences_of_state_derivative(lean_state):
    params = rd.DiskParams(mass=3.0, radius=0.7)
    a, b = lean_linearization(lean_state, params)
    x0 = np.array([0.0, 0.0, 0.0, lean_state[0], 0.0, *lean_state[1:]])
    rows, columns, step = [6, 5, 6, 7], [3, 5, 6, 7], 1e-6
    for j, column in enumerate(columns):
        e = np.zeros(8)
        e[column] = step
        slope = (rd.state_derivative(x0 + e, params=params) - rd.state_derivative(x0 - e, params=params)) / (2 * step)
        np.testing.assert_allclose(a[1:, j], slope[rows[1:]], atol=1e-6)
        assert a[0, j] == (1.0 if column == 6 else 0.0)
    for j in range(2):
        u = np.zeros(2)
        u[j] = step
        slope = (rd.state_derivative(x0, u, params) - rd.state_derivative(x0, -u, params)) / (2 * step)
        np.testing.assert_allclose(b[1:, j], slope[rows[1:]], atol=1e-6)


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
