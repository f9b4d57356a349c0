"""The Ray paths on an embedded local Ray: Tune sweeps (agents.sweep) and RLlib PPO (agents.rllib_train).

Skipped where Ray is not installed (the main test venv); .ci/run runs them in a second venv made with the
``ray`` and ``rllib`` extras, whose gymnasium is RLlib's pin, the lowest version pyproject.toml declares.
"""

import csv
import importlib.metadata
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

import rolling_disk_env as rd

pytest.importorskip("ray.tune")

ROOT = Path(__file__).parent.parent


def run_sweep(out: Path, *flags: str, search: str | None = None) -> subprocess.CompletedProcess:
    """``python -m agents.sweep`` as a user runs it, with its own search space if given."""
    if search is not None:
        (out.parent / "space.yml").write_text(search)
        flags = (*flags, "--search", str(out.parent / "space.yml"))
    command = [sys.executable, "-m", "agents.sweep", "--out", str(out), *flags]
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)


def read_trials(out: Path) -> list[dict]:
    with open(out / "trials.csv") as handle:
        return list(csv.DictReader(handle))


def test_two_trial_sweep_writes_its_table_and_a_best_config_that_train_py_trains(tmp_path):
    out = tmp_path / "sweep"
    result = run_sweep(out, "--samples", "2", "--timesteps", "2000")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    trials = read_trials(out)
    assert [trial["status"] for trial in trials] == ["done", "done"]
    assert float(trials[0]["return"]) >= float(trials[1]["return"])
    assert all(int(trial["steps"]) >= 2000 for trial in trials)
    for trial in trials:
        assert (out / "tune" / trial["trial"] / "model.zip").exists()
        assert (out / "tune" / trial["trial"] / "results.md").exists()
    assert f"| 1 | {trials[0]['trial']} | done |" in result.stdout

    import train

    best = yaml.safe_load((out / "best.yml").read_text())[rd.TASK_IDS["upright"]]
    assert best["learning_rate"] == pytest.approx(float(trials[0]["learning_rate"]))
    retrained = tmp_path / "retrain"
    arguments = ["--config", str(out / "best.yml"), "--timesteps", "512", "--eval-episodes", "2"]
    arguments += ["--out", str(retrained)]
    assert len(train.main(arguments)) == 3
    used = yaml.safe_load((retrained / "config.yml").read_text())[rd.TASK_IDS["upright"]]
    assert {**used, "n_timesteps": best["n_timesteps"]} == best


def test_asha_stops_the_trial_whose_return_falls_behind(tmp_path):
    # Two trials one after the other (2 CPUs each): learning rate 1e-3 holds the disk up by 20k steps, learning
    # rate 0 never learns; ASHA's one rung at 20k steps stops the second. The rollouts and minibatches are fixed here,
    # upright's block before the main job's (16 envs x 128 steps, 512): the main job's (32 x 64, 1024) learns later
    # (with it, ASHA let learning rate 0 run to the end), and with 16 envs an evaluation falls on 20k steps.
    out = tmp_path / "sweep"
    search = "learning_rate: {grid_search: [1.0e-3, 0.0]}\nn_envs: 16\nn_steps: 128\nbatch_size: 512\n"
    flags = ("--samples", "1", "--timesteps", "30000", "--grace-period", "20000", "--cpus-per-trial", "2")
    result = run_sweep(out, *flags, search=search)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    good, bad = read_trials(out)
    assert (good["status"], float(good["learning_rate"])) == ("done", 1e-3)
    assert int(good["steps"]) >= 30000 and float(good["return"]) > 300
    assert (bad["status"], float(bad["learning_rate"]), int(bad["steps"])) == ("stopped early", 0.0, 20000)
    assert float(bad["return"]) < 200
    assert not (out / "tune" / bad["trial"] / "model.zip").exists()  # stopped before the end of its training


def test_a_failing_trial_is_listed_with_its_error_and_fails_the_sweep(tmp_path):
    out = tmp_path / "sweep"
    result = run_sweep(out, "--samples", "1", "--timesteps", "2000", search="batch_size: {grid_search: [64, 1]}\n")
    assert result.returncode == 1, result.stdout[-3000:] + result.stderr[-3000:]
    trials = read_trials(out)
    assert [(trial["status"], trial["batch_size"]) for trial in trials] == [("done", "64"), ("error", "1")]
    assert (out / "tune" / trials[1]["trial"] / "error.txt").exists()
    assert "1 trial(s) failed" in result.stdout and (out / "best.yml").exists()


def test_ctrl_c_keeps_finished_trials_and_the_same_command_resumes(tmp_path):
    out = tmp_path / "sweep"
    (tmp_path / "space.yml").write_text("learning_rate: {grid_search: [1.0e-3, 1.0e-4]}\n")
    command = [sys.executable, "-m", "agents.sweep", "--out", str(out), "--search", str(tmp_path / "space.yml")]
    command += ["--samples", "1", "--timesteps", "4000", "--scheduler", "fifo", "--cpus-per-trial", "2"]
    # A session of its own, so that SIGINT to its process group is what Ctrl-C in a terminal sends. One trial runs
    # at a time (2 CPUs each): SIGINT comes when the second starts writing its run directory.
    with open(tmp_path / "first.log", "w") as log:
        process = subprocess.Popen(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + 300
        while len(list(out.glob("tune/*/config.yml"))) < 2 and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.1)
        os.killpg(process.pid, signal.SIGINT)
        assert process.wait(timeout=120) == 130, (tmp_path / "first.log").read_text()[-3000:]
    first = read_trials(out)
    assert [trial["status"] for trial in first] == ["done", "unfinished"]

    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "resuming the sweep" in result.stdout
    second = {trial["trial"]: trial for trial in read_trials(out)}
    assert second.keys() == {trial["trial"] for trial in first}
    assert {trial["status"] for trial in second.values()} == {"done"}
    assert second[first[0]["trial"]] == first[0]  # kept, not trained again


def test_a_sweep_runs_on_a_ray_cluster_started_apart_with_address_auto(tmp_path):
    # `ray start --head` on this machine stands for a cluster; the sweep ships the agents package to its workers.
    with socket.socket() as probe:
        probe.bind(("", 0))
        port = probe.getsockname()[1]
    command = [str(Path(sys.executable).parent / "ray"), "start", "--head", f"--port={port}", "--num-cpus=2", "--block"]
    environment = {**os.environ, "RAY_GRACEFUL_SHUTDOWN_DRAIN_TIMEOUT_S": "0"}  # no 30 s drain on SIGTERM
    with open(tmp_path / "head.log", "w") as log:
        head = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, env=environment)
    try:
        deadline = time.monotonic() + 120
        while "Ray runtime started" not in (tmp_path / "head.log").read_text() and time.monotonic() < deadline:
            assert head.poll() is None, (tmp_path / "head.log").read_text()
            time.sleep(0.5)
        out = tmp_path / "sweep"
        result = run_sweep(out, "--samples", "2", "--timesteps", "2000", "--address", "auto")
        assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
        assert [trial["status"] for trial in read_trials(out)] == ["done", "done"]
    finally:
        os.killpg(head.pid, signal.SIGTERM)  # the head and every process it started
        head.wait(timeout=120)
        # `ray start` leaves its address for `ray.init()` to join; without the cluster that would wait forever.
        current = Path(tempfile.gettempdir(), "ray", "ray_current_cluster")
        if current.exists() and current.read_text().strip().endswith(f":{port}"):
            current.unlink()


def test_a_resumed_sweep_refuses_other_settings(tmp_path):
    out = tmp_path / "sweep"
    out.mkdir()
    (out / "sweep.json").write_text('{"task": "upright"}\n')
    result = run_sweep(out, "--samples", "2", "--timesteps", "2000")
    assert result.returncode == 2 and "holds a sweep with other settings" in result.stderr


def test_one_rllib_iteration_on_the_native_vector_env_checkpoints_a_policy_that_evaluates_the_same(tmp_path, capsys):
    pytest.importorskip("ray.rllib.algorithms.ppo")
    from agents import rllib_train
    from agents.evaluate import results_table

    out = tmp_path / "rllib"
    flags = ["--iterations", "1", "--env-runners", "1", "--envs-per-runner", "4", "--eval-episodes", "10"]
    trained = rllib_train.main([*flags, "--out", str(out)])
    printed = capsys.readouterr().out
    assert trained["env_runner_envs"] == ["RollingDiskVectorEnv"]  # one remote runner, the native vector env
    batch = rllib_train.parse_args(flags).batch  # n_steps of agents/hyperparams/ppo.yml times the runner's 4 envs
    assert batch <= trained["steps"] < batch + 4 * 500
    table = results_table(trained["results"])
    assert table in printed and table in (out / "results.md").read_text()

    policy = rllib_train.load_policy(trained["checkpoint"])  # without Ray
    restored = rllib_train.evaluation(policy, "upright", 10, trained["results"][0].name)
    assert results_table(restored) == table
    np.testing.assert_array_equal(restored[0].returns, trained["results"][0].returns)

    more = rllib_train.main([*flags, "--restore", str(trained["checkpoint"]), "--out", str(tmp_path / "more")])
    assert more["iteration"] == 2 and more["steps"] >= trained["steps"] + batch


def test_the_rllib_venv_runs_the_lowest_gymnasium_pyproject_declares():
    pytest.importorskip("ray.rllib.algorithms.ppo")
    import tomllib

    with open(ROOT / "pyproject.toml", "rb") as handle:
        dependencies = tomllib.load(handle)["project"]["dependencies"]
    (declared,) = (re.search(r">=([\d.]+)", dep).group(1) for dep in dependencies if dep.startswith("gymnasium"))
    assert importlib.metadata.version("gymnasium") == declared
