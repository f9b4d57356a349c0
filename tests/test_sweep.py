"""The sweep's and the RLlib runner's parts that need no Ray: search spaces, flags, hyperparameter mapping, table."""

import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

import rolling_disk_env as rd
from agents import rllib_train, sweep
from agents.training import HYPERPARAMS, ConfigError, algorithm_kwargs, load_hyperparams, parse_zoo_expression

ROOT = Path(__file__).parent.parent


@pytest.mark.parametrize("task", sorted(rd.TASK_IDS))
@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_every_shipped_search_space_gives_blocks_the_algorithm_accepts(task, algo):
    space = sweep.load_search_space(sweep.SEARCH_SPACES / f"{algo}.yml")
    block = load_hyperparams(HYPERPARAMS / f"{algo}.yml", rd.TASK_IDS[task])
    for index in (0, -1):
        sample = {
            key: value if sweep._sampler(value) is None else sweep._sampler(value)[1][index]
            for key, value in space.items()
        }
        algorithm_kwargs(algo, sweep.apply_sample(block, sample))


def test_policy_kwargs_arguments_are_set_inside_the_zoo_string_keeping_the_others():
    block = {"policy_kwargs": "dict(net_arch=[64, 64], activation_fn=nn.Tanh, log_std_init=-1.0)", "gamma": 0.99}
    updated = sweep.apply_sample(block, {"policy_kwargs.net_arch": [128, 128], "gamma": 0.995})
    assert updated["policy_kwargs"] == "dict(net_arch=[128, 128], activation_fn=nn.Tanh, log_std_init=-1.0)"
    assert updated["gamma"] == 0.995 and block["gamma"] == 0.99
    assert parse_zoo_expression(updated["policy_kwargs"])["net_arch"] == [128, 128]
    added = sweep.apply_sample({"policy_kwargs": "dict(net_arch=[64])"}, {"policy_kwargs.ortho_init": False})
    assert added["policy_kwargs"] == "dict(net_arch=[64], ortho_init=False)"
    assert sweep.apply_sample({}, {"policy_kwargs.net_arch": [8]})["policy_kwargs"] == "dict(net_arch=[8])"


def test_grid_points_multiply_the_samples():
    space = {"learning_rate": {"grid_search": [1e-3, 1e-4]}, "gamma": {"grid_search": [0.9, 0.99, 0.999]}}
    assert sweep.expected_trials(space, 2) == 12
    assert sweep.expected_trials({"gamma": {"choice": [0.9, 0.99]}}, 2) == 2


@pytest.mark.parametrize(
    ("search", "flags", "message"),
    [
        ("learning_rate: {lognormal: [1, 2]}", [], "unknown sampler 'lognormal'"),
        ("learning_rate: {loguniform: 0.001}", [], "needs a list of arguments"),
        ("learnin_rate: {loguniform: [1.0e-5, 1.0e-3]}", [], "learnin_rate"),
        ("n_timesteps: {choice: [1000, 2000]}", [], "cannot be searched"),
        ("policy_kwargs.net_arch: {choice: [[64], [128]]}", ["--algo", "sac"], None),
        ("- 1\n- 2", [], "must map hyperparameters"),
        ("gamma: {choice: [0.9]}", ["--samples", "0"], "--samples: must be positive"),
        ("gamma: {choice: [0.9]}", ["--cpus-per-trial", "-1"], "--cpus-per-trial: must be positive"),
        ("gamma: {choice: [0.9]}", ["--timesteps", "1000", "--grace-period", "2000"], "--grace-period 2000"),
        ("gamma: {choice: [0.9]}", ["--algo", "a2c"], "invalid choice: 'a2c'"),
    ],
)
def test_bad_flags_and_search_spaces_are_argument_errors(tmp_path, capsys, search, flags, message):
    path = tmp_path / "space.yml"
    path.write_text(search)
    argv = ["--search", str(path), "--out", str(tmp_path / "out"), *flags]
    if message is None:
        assert sweep.parse_args(argv).space == {"policy_kwargs.net_arch": {"choice": [[64], [128]]}}
        return
    with pytest.raises(SystemExit) as exit_info:
        sweep.parse_args(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("module", ["agents.sweep", "agents.rllib_train"])
def test_help_and_argument_errors_answer_before_ray_and_torch_load(module):
    code = (
        "import sys, runpy\n"
        "for argv in (['--help'], ['--task', 'nope']):\n"
        "    sys.argv = ['x', *argv]\n"
        "    try:\n"
        f"        runpy.run_module({module!r}, run_name='__main__')\n"
        "    except SystemExit as exit:\n"
        "        print('exit', exit.code)\n"
        "print('loaded', sorted({'ray', 'torch'} & set(sys.modules)))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert result.stdout.splitlines()[-3:] == ["exit 0", "exit 2", "loaded []"], result.stdout + result.stderr
    assert "Traceback" not in result.stderr and "invalid choice: 'nope'" in result.stderr


def test_trials_are_ranked_finished_first_by_return():
    def trial(name, status, final=None, value=None, steps=0):
        result = {} if value is None else {"return": value, "success": 0.5, "timesteps": steps, "time_total_s": 3.0}
        if final:
            result["final"] = True
        return SimpleNamespace(path=f"/x/{name}", status=status, last_result=result, config={"gamma": 0.99})

    trials = [
        trial("a", "TERMINATED", value=400.0, steps=10_000),
        trial("b", "TERMINATED", final=True, value=300.0, steps=20_000),
        trial("c", "ERROR"),
        trial("d", "TERMINATED", final=True, value=350.0, steps=20_000),
        trial("e", "RUNNING", value=90.0, steps=10_000),
    ]
    rows = sweep.trial_rows(trials, ["gamma"])
    assert [(row["trial"], row["status"]) for row in rows] == [
        ("d", "done"),
        ("b", "done"),
        ("a", "stopped early"),
        ("e", "unfinished"),
        ("c", "error"),
    ]
    table = sweep.markdown_table(rows, ["gamma"]).splitlines()
    assert table[0] == "| # | trial | status | return | success | steps | time | gamma |"
    assert table[2] == "| 1 | d | done | 350.0 | 50% | 20000 | 3 s | 0.99 |"
    assert table[-1] == "| 5 | c | error | nan | - | 0 | 0 s | 0.99 |"


def test_rllib_takes_sb3_ppo_hyperparameters_under_its_own_names():
    block = load_hyperparams(HYPERPARAMS / "ppo.yml", rd.TASK_IDS["upright"])
    training, model, n_steps = rllib_train.rllib_hyperparams(block)
    assert n_steps == block["n_steps"]
    assert training["lr"] == block["learning_rate"] and training["minibatch_size"] == block["batch_size"]
    assert training["num_epochs"] == block["n_epochs"] and training["lambda_"] == block["gae_lambda"]
    assert training["clip_param"] == block["clip_range"] and training["entropy_coeff"] == block["ent_coef"]
    assert training["vf_loss_coeff"] == 0.5 and training["grad_clip"] == 0.5  # SB3's defaults
    assert training["vf_clip_param"] == math.inf and training["use_kl_loss"] is False
    assert model == {
        "fcnet_hiddens": [64, 64],
        "vf_share_layers": False,
        "free_log_std": True,
        "fcnet_activation": "Tanh",
    }
    with pytest.raises(ConfigError, match="use_sde"):
        rllib_train.rllib_hyperparams({**block, "use_sde": True})
    with pytest.raises(ConfigError, match="learning_rate"):
        rllib_train.rllib_hyperparams({**block, "learning_rate": "lin_3e-4"})


def test_rllib_iterations_default_to_the_blocks_timesteps(tmp_path):
    args = rllib_train.parse_args(["--env-runners", "2", "--envs-per-runner", "4", "--out", str(tmp_path)])
    block = load_hyperparams(HYPERPARAMS / "ppo.yml", rd.TASK_IDS["upright"])
    assert args.batch == block["n_steps"] * 2 * 4
    assert args.iterations == math.ceil(block["n_timesteps"] / args.batch)


@pytest.mark.parametrize(("runners", "envs"), [(1, 8), (0, 1), (4, 64)])
def test_rllib_minibatches_are_at_most_an_iterations_batch(runners, envs, tmp_path, capsys):
    # RLlib raises where minibatch_size > train_batch_size_per_learner: upright's block (1024) against the default
    # runner's 8 disks x 64 steps did.
    block = load_hyperparams(HYPERPARAMS / "ppo.yml", rd.TASK_IDS["upright"])
    flags = ["--env-runners", str(runners), "--envs-per-runner", str(envs), "--out", str(tmp_path)]
    args = rllib_train.parse_args(flags)
    assert args.batch == block["n_steps"] * max(1, runners) * envs
    assert args.training["minibatch_size"] == min(block["batch_size"], args.batch)
    said = capsys.readouterr().out
    assert (f"minibatches of {args.batch} steps" in said) == (block["batch_size"] > args.batch)
