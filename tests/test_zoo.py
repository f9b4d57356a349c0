"""The hyperparameter files are rl-baselines3-zoo's format for real: rl_zoo3's train reads them unchanged for every
per-task id, and train.py reads them too, with the zoo's policy_kwargs strings parsed without eval."""

import importlib
import importlib.util
import json
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import pytest
import yaml
from stable_baselines3 import PPO, SAC
from torch import nn

import rolling_disk_env as rd
from agents.evaluate import ALGORITHMS
from agents.training import HYPERPARAMS, ConfigError, algorithm_kwargs, load_hyperparams, parse_zoo_expression

ROOT = Path(__file__).resolve().parents[1]
IDS = [rd.TASK_IDS["upright"], rd.TASK_IDS["circle"]]
"""The ids the zoo trains with the project's files here (goto's block is there too, and loads)."""
"""The per-task ids with hyperparameters."""
ZOO_RUNS = [(algo, env_id) for algo in ("ppo", "sac") for env_id in IDS]


def test_every_file_has_a_block_per_task_id_and_nothing_else():
    for algo in ALGORITHMS:
        blocks = yaml.safe_load((HYPERPARAMS / f"{algo}.yml").read_text())
        assert sorted(blocks) == sorted(rd.TASK_IDS.values()), algo
        for env_id in rd.TASK_IDS.values():
            block = load_hyperparams(HYPERPARAMS / f"{algo}.yml", env_id)
            assert isinstance(block["policy_kwargs"], str)  # the zoo's form, which it evaluates
            assert isinstance(algorithm_kwargs(algo, block)["policy_kwargs"], dict)


def test_the_tuned_values_are_kept():
    upright = load_hyperparams(HYPERPARAMS / "ppo.yml", "RollingDiskUpright-v0")
    ppo = algorithm_kwargs("ppo", upright)
    assert ppo["policy_kwargs"] == {"net_arch": [64, 64], "activation_fn": nn.Tanh, "log_std_init": -1.0}
    assert (ppo["n_steps"], ppo["batch_size"], ppo["learning_rate"], ppo["clip_range"]) == (64, 1024, 1e-3, 0.2)
    assert (upright["n_timesteps"], upright["n_envs"], upright["n_epochs"]) == (6e4, 32, 10)
    circle = load_hyperparams(HYPERPARAMS / "ppo.yml", "RollingDiskCircle-v0")
    assert (circle["n_timesteps"], circle["n_envs"], circle["n_steps"], circle["batch_size"]) == (5e5, 8, 256, 256)
    assert (circle["learning_rate"], circle["n_epochs"], circle["normalize"]) == (3e-4, 10, True)
    goto = load_hyperparams(HYPERPARAMS / "ppo.yml", "RollingDiskGoto-v0")
    assert goto == {**circle, "n_timesteps": 2e6}


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("dict(net_arch=[64, 64], activation_fn=nn.Tanh, log_std_init=-1.0)", None),
        ("dict(net_arch=dict(pi=[32], vf=[32, 32]), activation_fn=nn.ReLU, ortho_init=False)", None),
        ("{'net_arch': (8,), 'activation_fn': nn.LeakyReLU, 'x': None, 'y': 'z', 'e': nn.ELU}", None),
        ("dict()", {}),
    ],
)
def test_zoo_expressions_are_read_as_python_would(text, value):
    expected = eval(text, {"nn": nn})  # the zoo's way, here on trusted strings, as the reference
    assert parse_zoo_expression(text) == (expected if value is None else value)


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("dict(activation_fn=os.system)", "'os.system'"),
        ("__import__('os').system('true')", "\"__import__('os').system('true')\""),
        ("dict(net_arch=[64] * 2)", "'[64] * 2'"),
        ("dict(activation_fn=nn.Module)", "'nn.Module'"),
        ("dict(activation_fn=tanh)", "'tanh'"),
        ("dict(**kwargs)", "'dict(**kwargs)'"),
        ("dict(", "not a Python expression"),
    ],
)
def test_anything_else_is_refused_by_name(text, named):
    with pytest.raises(ConfigError, match="policy_kwargs") as error:
        parse_zoo_expression(text)
    assert named in str(error.value)


def test_schedules_are_linear_from_the_value_to_zero():
    kwargs = algorithm_kwargs("ppo", {"learning_rate": "lin_3e-4", "clip_range": "lin_0.2"})
    assert kwargs["learning_rate"](1.0) == pytest.approx(3e-4) and kwargs["learning_rate"](0.5) == pytest.approx(1.5e-4)
    assert kwargs["clip_range"](0.0) == 0.0


ZOO_DRIVER = """
import json, sys, traceback
from rl_zoo3.train import train

for argv in sys.argv[1:]:
    print("zoo run:", argv, flush=True)
    sys.argv = ["rl_zoo3.train", *json.loads(argv)]
    try:
        train()
        print("zoo run passed:", argv, flush=True)
    except (Exception, SystemExit):
        traceback.print_exc(file=sys.stdout)
"""
"""rl_zoo3's ``train`` (what ``python -m rl_zoo3.train`` runs) for each command line it is given (a JSON list), one
after the other in one process, which imports torch, SB3 and the zoo once instead of once a run (4 s of the 7 to 11 a
run took). Each run's output follows a line ``zoo run: <its arguments>``, and ends with ``zoo run passed: <its
arguments>`` where it trained and saved its model."""


@pytest.fixture(scope="module")
def zoo_runs(tmp_path_factory):
    """rl_zoo3's train, 1000 steps of each algorithm on each per-task id, with the project's files; returns the
    folder, each run's arguments and each run's output (keyed by its arguments)."""
    if importlib.util.find_spec("rl_zoo3") is None:
        pytest.skip("rl_zoo3 is not installed (pip install -e '.[test]')")
    folder = tmp_path_factory.mktemp("zoo")
    fixed = "--gym-packages rolling_disk_env -n 1000 --seed 0 --eval-freq -1 --num-threads 1".split()
    commands = {  # each a JSON list of arguments
        (algo, env_id): json.dumps(
            ["--algo", algo, "--env", env_id, "-conf", str(HYPERPARAMS / f"{algo}.yml"), "-f", str(folder), *fixed]
        )
        for algo, env_id in ZOO_RUNS
    }
    process = subprocess.run(
        [sys.executable, "-c", ZOO_DRIVER, *commands.values()],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=600,
        check=False,
    )
    runs = process.stdout.split("zoo run: ")[1:]
    return folder, commands, {argv: run for argv, _, run in (text.partition("\n") for text in runs)}


@pytest.mark.xdist_group("zoo")  # one worker runs the module's fixture, once
@pytest.mark.parametrize(("algo", "env_id"), ZOO_RUNS)
def test_rl_zoo_trains_with_the_project_files(zoo_runs, algo, env_id):
    folder, commands, outputs = zoo_runs
    output = outputs.get(commands[algo, env_id], "(not run: an earlier run ended the process)")
    assert output.endswith(f"zoo run passed: {commands[algo, env_id]}\n"), output[-3000:]
    run = folder / algo / f"{env_id}_1"
    model = {"ppo": PPO, "sac": SAC}[algo].load(run / f"{env_id}.zip", device="cpu")
    assert model.num_timesteps >= 1000
    block = load_hyperparams(HYPERPARAMS / f"{algo}.yml", env_id)
    activation = {"ppo": nn.Tanh, "sac": nn.ReLU}[algo]
    assert model.policy_kwargs.get("activation_fn", nn.ReLU) == activation
    assert model.n_envs == block.get("n_envs", 1)  # the zoo's default: 1
    if algo == "ppo":  # the zoo's default rollout is 2048 steps an env: the block's own came through
        assert (model.n_steps, model.batch_size) == (block["n_steps"], block["batch_size"])
    assert (run / env_id / "vecnormalize.pkl").exists()  # normalize: true
    assert model.observation_space == gym.make(env_id).observation_space  # the id's task


def test_an_activation_given_as_a_string_is_refused():
    # The old files' mapping with activation_fn: tanh made SB3 fail with "'str' object is not callable".
    with pytest.raises(ConfigError, match="activation_fn must be a class"):
        algorithm_kwargs("ppo", {"policy_kwargs": {"net_arch": [64], "activation_fn": "tanh"}})
    assert algorithm_kwargs("sac", {"policy_kwargs": {"net_arch": [64]}})["policy_kwargs"] == {"net_arch": [64]}


@pytest.mark.parametrize(("task", "env_id"), rd.TASK_IDS.items())
def test_each_task_has_its_own_id(task, env_id):
    spec = gym.spec(env_id)
    assert spec.kwargs == {"task": task}
    assert spec.max_episode_steps == rd.TASK_MAX_STEPS[task] and spec.reward_threshold is not None
    assert gym.make(env_id).unwrapped.task.name == task
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    assert isinstance(envs, rd.RollingDiskVectorEnv) and envs.task.name == task


def test_the_general_id_stays_upright_by_default_and_takes_every_task():
    assert gym.make(rd.ENV_ID).unwrapped.task.name == "upright"
    assert gym.make(rd.ENV_ID, task="circle").unwrapped.task.name == "circle"


def test_registration_is_idempotent():
    # SubprocVecEnv's children import the package again: no re-registration, no warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        importlib.reload(rd)
    assert all(env_id in gym.registry for env_id in [rd.ENV_ID, *rd.TASK_IDS.values()])
