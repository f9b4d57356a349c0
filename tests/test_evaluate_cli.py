"""python -m agents.evaluate as a user runs it: a model's task read from its run, one-line errors, the baseline by
its role, a live view that runs headless, and an episode plot whose panels keep their size."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from agents.evaluate import episode_figure, record_episode, run_settings
from agents.evaluate import main as evaluate_main
from agents.training import train

ROOT = Path(__file__).resolve().parents[1]


def run(*args: str) -> subprocess.CompletedProcess:
    environment = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    return subprocess.run(
        [sys.executable, "-m", "agents.evaluate", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env=environment,
    )


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """A tiny PPO run of each task, by train.py's training function."""
    block = {"n_timesteps": 256, "n_envs": 1, "normalize": True, "n_steps": 256, "batch_size": 64, "n_epochs": 1}
    folders = {}
    for task in ("upright", "circle"):
        folders[task] = tmp_path_factory.mktemp(task)
        train(task, "ppo", block, folders[task], eval_episodes=2, progress_bar=False)
    return folders


@pytest.mark.xdist_group("evaluate_cli runs")  # one worker trains the module fixture's runs, once
def test_a_model_is_evaluated_on_its_runs_task(runs, capsys):
    # The circle run's model reads 8 observations: evaluated on upright's 4 it used to fail deep inside torch.
    result = evaluate_main(["--model", str(runs["circle"] / "model.zip"), "--episodes", "2"])
    assert np.all(np.isfinite(result.returns))
    assert "| agent | return (mean +- std) | success |" in capsys.readouterr().out
    assert run_settings(runs["circle"] / "model.zip") == ("circle", {})


def test_the_runs_env_settings_are_read(tmp_path):
    config = {"RollingDiskCircle-v0": {"n_timesteps": 10, "env_kwargs": {"max_steer_torque": 8.0}}}
    (tmp_path / "config.yml").write_text(yaml.safe_dump(config))
    assert run_settings(tmp_path / "model.zip") == ("circle", {"max_steer_torque": 8.0})
    # Runs saved before the per-task ids: the general id with the task in env_kwargs.
    config = {"RollingDisk-v0-circle": {"env_kwargs": {"task": "circle"}}}
    (tmp_path / "config.yml").write_text(yaml.safe_dump(config))
    assert run_settings(tmp_path / "model.zip") == ("circle", {})


@pytest.mark.xdist_group("evaluate_cli runs")  # one worker trains the module fixture's runs, once
def test_a_task_that_contradicts_the_run_is_a_one_line_error(runs):
    process = run("--model", str(runs["upright"] / "model.zip"), "--task", "circle")
    assert process.returncode == 2
    assert "Traceback" not in process.stderr
    last = process.stderr.strip().splitlines()[-1]
    assert "--task circle contradicts the model's run" in last and "'upright'" in last


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--agent", "ppo"],
            "unknown agent 'ppo': choose baseline, lqr, passive, or give a trained model with --model",
        ),
        (["--model", "runs/none/best_model.zip"], "no such model file: runs/none/best_model.zip"),
        (["--episodes", "0"], "--episodes: must be an integer >= 1"),
        (["--agent", "passive", "--model", "train.py"], "give either --agent or --model"),
    ],
)
def test_bad_arguments_are_one_line_errors(args, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        evaluate_main(args)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.parametrize(("task", "controller"), [("upright", "UprightLQR"), ("circle", "CircleLQR")])
def test_the_baseline_is_the_tasks_classical_controller(task, controller, capsys):
    for agent in ("baseline", "lqr"):
        result = evaluate_main(["--task", task, "--agent", agent, "--episodes", "2"])
        assert result.name == f"baseline: {controller}"
        assert result.successes.all()
    assert f"| baseline: {controller} |" in capsys.readouterr().out


def test_render_human_shows_an_episode_headless():
    process = run("--agent", "passive", "--episodes", "1", "--render", "human")
    assert process.returncode == 0, process.stderr
    assert "watched seed 10000: return" in process.stdout


def test_the_track_panel_of_an_upright_episode_is_not_squeezed():
    # Upright rolling draws a nearly straight track: equal axes shrank its panel to a strip.
    from agents.baselines import UprightLQR

    figure = episode_figure(record_episode(UprightLQR(), task="upright"), "upright")
    figure.canvas.draw()
    lean, _, _, track = (axes.get_position() for axes in figure.axes)
    assert track.height > 0.9 * lean.height and track.width > 0.9 * lean.width
    x_low, x_high = figure.axes[3].get_xlim()
    y_low, y_high = figure.axes[3].get_ylim()
    box = figure.axes[3].get_window_extent()
    # Still equal scales: metres per pixel agree along x and y.
    assert (x_high - x_low) / box.width == pytest.approx((y_high - y_low) / box.height, rel=0.02)
