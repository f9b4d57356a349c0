"""train.py as a user runs it: arguments checked before anything heavy loads (numpy, torch, SB3), clean one-line
errors, the run directory printed, evaluations reported while training, and Ctrl-C handled; and
agents.training.train as the Ray sweeps call it."""

import math
import pickle
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import rolling_disk_env as rd
import train
from agents import evaluate
from agents.evaluate import ALGORITHMS
from agents.training import EVAL_EVERY, load_hyperparams

ROOT = Path(__file__).resolve().parents[1]
MAIN_JOB_ENVS = load_hyperparams(train.HYPERPARAMS / "ppo.yml", rd.TASK_IDS["upright"])["n_envs"]
FIRST_EVALUATION = f"{math.ceil(EVAL_EVERY / MAIN_JOB_ENVS) * MAIN_JOB_ENVS} steps: eval return "
"""How the main job's first evaluation line starts: at the first step count from EVAL_EVERY on (the steps come
n_envs at a time)."""


HEAVY = {"numpy", "gymnasium", "numba", "torch", "stable_baselines3"}
"""What train.py must not import before its arguments are checked."""


def run(*args: str, timeout: float = 120, **kwargs) -> tuple[subprocess.CompletedProcess, set[str]]:
    """``python -W error train.py *args`` (every warning an error); returns the process (its stderr without the import
    log) and the modules it imported (``python -X importtime`` writes a line to stderr for each)."""
    process = subprocess.run(
        [sys.executable, "-W", "error", "-X", "importtime", "train.py", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
        **kwargs,
    )
    lines = process.stderr.splitlines(keepends=True)
    modules = {line.rsplit("|", 1)[-1].strip() for line in lines if line.startswith("import time:")}
    process.stderr = "".join(line for line in lines if not line.startswith("import time:"))
    return process, modules


@pytest.mark.parametrize(
    "args",
    [
        ["--timesteps", "0"],
        ["--timesteps", "-5"],
        ["--timesteps", "1e5"],
        ["--n-envs", "0"],
        ["--eval-episodes", "0"],
        ["--threads", "0"],
        ["--seed", "-1"],
        ["--verbose", "3"],
        ["--task", "balance"],
    ],
)
def test_bad_arguments_exit_2_at_once_without_a_traceback(args, tmp_path):
    process, modules = run(*args, "--out", str(tmp_path / "run"), timeout=20)
    assert process.returncode == 2
    assert not modules & HEAVY  # parsed before numpy, torch and SB3 load, so nothing trains
    assert "Traceback" not in process.stderr
    assert process.stderr.strip().splitlines()[-1].startswith("python train.py: error: argument")
    assert not (tmp_path / "run").exists()


def test_help_loads_nothing_heavy_and_shows_defaults_and_examples():
    process, modules = run("--help", timeout=20)
    assert process.returncode == 0
    assert not modules & HEAVY
    assert "(default: upright)" in process.stdout and "(default: 100)" in process.stdout
    assert "examples:" in process.stdout and "python train.py --task circle" in process.stdout


def test_the_cli_choices_are_the_packages():
    # The tasks are those with a hyperparameter block, in every algorithm's file, by the task's id.
    ids = {rd.TASK_IDS[task] for task in train.TASKS}
    for algo in train.ALGORITHMS:
        assert set(yaml.safe_load((train.HYPERPARAMS / f"{algo}.yml").read_text())) == ids, algo
    assert train.ALGORITHMS == tuple(ALGORITHMS)


def test_a_missing_config_file_is_a_one_line_error(tmp_path):
    process, _ = run("--config", str(tmp_path / "none.yml"), timeout=20)
    assert process.returncode == 2
    assert "Traceback" not in process.stderr
    assert process.stderr.strip().splitlines()[-1].endswith(f"no such file: {tmp_path / 'none.yml'}")


@pytest.mark.parametrize(
    ("blocks", "message"),
    [
        ({"RollingDisk-v0": {"n_timesteps": 10}}, "has no block 'RollingDiskUpright-v0'"),
        ({"RollingDiskUpright-v0": {"n_timesteps": 10, "policy_kwargs": "dict(f=os.system)"}}, "'os.system'"),
    ],
)
def test_a_bad_config_is_a_one_line_error(tmp_path, blocks, message):
    config = tmp_path / "bad.yml"
    config.write_text(yaml.safe_dump(blocks))
    process, _ = run("--config", str(config), "--out", str(tmp_path / "run"), timeout=60)
    assert process.returncode == 1
    assert "Traceback" not in process.stderr
    assert len(process.stderr.strip().splitlines()) == 1
    assert message in process.stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    ("block", "message"),
    [
        ({"learning_rate": "exp_1e-3"}, "learning_rate: 'exp_1e-3' is neither a number nor a linear schedule"),
        ({"n_stepz": 64}, "unknown hyperparameter(s) ['n_stepz'] for ppo"),
        ({"env_kwargs": {"dt": -1}}, "env_kwargs: dt must be a finite number > 0"),
        ({"env_kwargs": {"task": "circle"}}, "env_kwargs sets task 'circle'"),
        ({"normalize": "yes"}, "normalize: 'yes' is not allowed"),
        ({"n_timesteps": 0}, "timesteps must be a positive integer, got 0"),
        ({"n_timesteps": 2.5}, "timesteps must be a positive integer, got 2.5"),
    ],
)
def test_bad_hyperparameters_are_named_before_training(tmp_path, block, message):
    config = tmp_path / "bad.yml"
    config.write_text(yaml.safe_dump({"RollingDiskUpright-v0": {"n_timesteps": 10, **block}}))
    with pytest.raises(SystemExit) as exit_info:
        train.main(["--config", str(config), "--out", str(tmp_path / "run")])
    assert str(exit_info.value.code).startswith(f"train.py: error: {config}: ")
    assert message in str(exit_info.value.code)
    assert not (tmp_path / "run").exists()


def test_a_run_prints_its_directory_and_every_evaluation_and_no_warning(tmp_path):
    out = tmp_path / "run"
    process, _ = run("--timesteps", "10000", "--eval-episodes", "2", "--out", str(out), "--verbose", "1")
    assert process.returncode == 0, process.stderr  # with every warning an error (run's -W error)
    assert "Warning" not in process.stdout + process.stderr
    lines = process.stdout.strip().splitlines()
    assert lines[0] == f"run directory: {out}" and lines[-1] == f"run directory: {out}"
    # Off a terminal, each evaluation is a line (on a terminal, the progress bar's postfix shows it).
    assert any(line.startswith(FIRST_EVALUATION) and "success" in line for line in lines)
    assert "rollout/" in process.stdout  # --verbose 1: SB3's training logs
    for name in ("model.zip", "best_model.zip", "vecnormalize.pkl", "config.yml", "command.txt", "results.md"):
        assert (out / name).exists(), name
    # The best model keeps the observation statistics it was evaluated with, which later training changes.
    best = pickle.loads((out / "best_vecnormalize.pkl").read_bytes())
    final = pickle.loads((out / "vecnormalize.pkl").read_bytes())
    assert best.obs_rms.count < final.obs_rms.count
    assert evaluate.normalization_file(out / "best_model.zip") == out / "best_vecnormalize.pkl"
    assert evaluate.normalization_file(out / "model.zip") == out / "vecnormalize.pkl"
    assert list((out / "tb").iterdir())
    assert "RollingDiskUpright-v0" in yaml.safe_load((out / "config.yml").read_text())


def test_a_run_directory_that_holds_a_run_is_not_overwritten(tmp_path):
    # Given with --out: refused at once, naming --out; the default one: numbered, as rl-baselines3-zoo's.
    out = tmp_path / "run"
    out.mkdir()
    assert not train.holds_a_run(out)  # an empty folder is used
    (out / "results.md").write_text("# a previous run\n")
    process, modules = run("--out", str(out), timeout=20)
    assert process.returncode == 2 and not modules & HEAVY
    assert (
        process.stderr.strip()
        .splitlines()[-1]
        .endswith(f"--out {out} holds a previous run (its results or a model): choose another --out")
    )
    assert train.new_run_directory(out) == tmp_path / "run_2"
    (tmp_path / "run_2").mkdir()
    (tmp_path / "run_2" / "model.zip").write_text("")
    assert train.new_run_directory(out) == tmp_path / "run_3"
    assert train.new_run_directory(tmp_path / "other") == tmp_path / "other"


def test_ctrl_c_saves_evaluates_and_prints_the_run_directory(tmp_path):
    out = tmp_path / "run"
    process = subprocess.Popen(
        [sys.executable, "train.py", "--timesteps", "1000000", "--eval-episodes", "2", "--out", str(out)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # A shell without job control starts background commands with SIGINT ignored: restore Ctrl-C.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert process.stdout.readline() == f"run directory: {out}\n"
        assert process.stdout.readline().startswith(FIRST_EVALUATION)
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    assert "Traceback" not in stderr
    assert "interrupted" in stdout and "(interrupted)" in (out / "results.md").read_text()
    assert stdout.strip().splitlines()[-1] == f"run directory: {out}"
    assert (out / "model.zip").exists() and (out / "vecnormalize.pkl").exists()


def test_train_reports_every_evaluation_and_returns_the_table(tmp_path):
    from agents.training import train as train_function

    reports = []
    results = train_function(
        "upright",
        "ppo",
        {"n_timesteps": 1, "n_envs": 4, "normalize": True, "n_steps": 1250, "batch_size": 500, "n_epochs": 1},
        tmp_path,
        timesteps=20_000,
        eval_episodes=2,
        progress_bar=False,
        on_evaluation=lambda *report: reports.append(report),
    )
    assert [steps for steps, _, _ in reports] == [10_000, 20_000]
    for _, mean_return, success_rate in reports:
        assert math.isfinite(mean_return) and 0 <= success_rate <= 1
    assert [result.name for result in results][1:] == ["passive disk (zero torque)", "baseline: UprightLQR"]
    assert (tmp_path / "eval" / "evaluations.npz").exists()


def test_train_refuses_bad_arguments_before_writing_anything(tmp_path):
    from agents.training import ConfigError
    from agents.training import train as train_function

    block = {"n_timesteps": 100}
    for kwargs in ({"task": "balance"}, {"algo": "dqn"}, {"timesteps": 0}, {"n_envs": True}, {"threads": 0}):
        arguments = {"task": "upright", "algo": "ppo", **kwargs}
        options = {key: value for key, value in arguments.items() if key not in ("task", "algo")}
        with pytest.raises(ConfigError):
            train_function(arguments["task"], arguments["algo"], block, tmp_path / "run", **options)
    assert not (tmp_path / "run").exists()
