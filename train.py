"""Train an agent on RollingDisk-v0 with Stable-Baselines3 (the project's main job).

    python train.py                                  # PPO on task "upright", the README's main job
    python train.py --task circle --algo sac --timesteps 200000 --seed 3

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (rl-baselines3-zoo's format). The run directory
(``--out``, default ``runs/<task>_<algo>_<seed>``) receives ``model.zip``, ``best_model.zip`` (EvalCallback),
``vecnormalize.pkl``, ``config.yml`` (the hyperparameters used), ``command.txt``, TensorBoard logs in ``tb/`` and
``results.md``: mean +- std return and success rate over seeded evaluation episodes for the trained agent, the
passive disk and the classical baseline. Ctrl-C stops training and still saves and evaluates the model.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
import warnings
from pathlib import Path

import torch
import yaml
from stable_baselines3.common.callbacks import EvalCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize
from tqdm import TqdmExperimentalWarning

import rolling_disk_env as rd
from agents.baselines import BASELINES
from agents.evaluate import ALGORITHMS, EVAL_SEED, NormalizedPolicy, PassiveAgent, evaluate
from rolling_disk_env.tasks import TASKS

ACTIVATIONS = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU, "elu": torch.nn.ELU}
HYPERPARAMS = Path(__file__).parent / "agents" / "hyperparams"


def config_key(task: str) -> str:
    """The YAML key of a task: the env id for the default task, ``<env id>-<task>`` otherwise."""
    return rd.ENV_ID if task == "upright" else f"{rd.ENV_ID}-{task}"


def load_hyperparams(path: Path, task: str) -> dict:
    """The block of ``task`` in a zoo-format YAML file, with policy_kwargs and schedules turned into objects."""
    with open(path) as handle:
        blocks = yaml.safe_load(handle)
    key = config_key(task)
    if key not in blocks:
        raise SystemExit(f"{path} has no block {key!r} for task {task!r}; blocks: {sorted(blocks)}")
    return dict(blocks[key])


def algorithm_kwargs(hyperparams: dict) -> dict:
    """SB3 keyword arguments from a zoo block (without the keys train.py handles itself)."""
    kwargs = {
        k: v for k, v in hyperparams.items() if k not in {"n_timesteps", "policy", "n_envs", "normalize", "env_kwargs"}
    }
    policy_kwargs = dict(kwargs.pop("policy_kwargs", {}) or {})
    if "activation_fn" in policy_kwargs:
        name = policy_kwargs["activation_fn"]
        if name not in ACTIVATIONS:
            raise SystemExit(f"unknown activation_fn {name!r}; choose from {sorted(ACTIVATIONS)}")
        policy_kwargs["activation_fn"] = ACTIVATIONS[name]
    if policy_kwargs:
        kwargs["policy_kwargs"] = policy_kwargs
    for name in ("learning_rate", "clip_range"):
        value = kwargs.get(name)
        if isinstance(value, str) and value.startswith("lin_"):
            start = float(value.removeprefix("lin_"))
            kwargs[name] = lambda progress, start=start: progress * start
    return kwargs


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description="Train an SB3 agent on RollingDisk-v0.")
    parser.add_argument("--task", choices=sorted(TASKS), default="upright")
    parser.add_argument("--algo", choices=sorted(ALGORITHMS), default="ppo")
    parser.add_argument("--timesteps", type=int, help="total environment steps (default: the config's)")
    parser.add_argument("--n-envs", type=int, help="parallel environments (default: the config's)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, help="run directory (default: runs/<task>_<algo>_<seed>)")
    parser.add_argument("--config", type=Path, help="hyperparameter YAML (default: agents/hyperparams/<algo>.yml)")
    parser.add_argument("--eval-episodes", type=int, default=100, help="seeded episodes in the final table")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads (1 is fastest on 2 cores)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    # SB3's progress bar uses tqdm's rich front end, which warns on every run that it is experimental.
    warnings.filterwarnings("ignore", category=TqdmExperimentalWarning)
    torch.set_num_threads(args.threads)
    out = args.out or Path("runs") / f"{args.task}_{args.algo}_{args.seed}"
    out.mkdir(parents=True, exist_ok=True)
    config_path = args.config or HYPERPARAMS / f"{args.algo}.yml"
    hyperparams = load_hyperparams(config_path, args.task)
    timesteps = args.timesteps or int(hyperparams["n_timesteps"])
    n_envs = args.n_envs or int(hyperparams.get("n_envs", 1))
    env_kwargs = {**hyperparams.get("env_kwargs", {}), "task": args.task}
    (out / "command.txt").write_text(shlex.join([sys.executable, *sys.argv]) + "\n")
    (out / "algo.txt").write_text(args.algo + "\n")
    (out / "config.yml").write_text(yaml.safe_dump({config_key(args.task): hyperparams}, sort_keys=False))

    env = make_vec_env(rd.ENV_ID, n_envs=n_envs, seed=args.seed, env_kwargs=env_kwargs, vec_env_cls=DummyVecEnv)
    eval_env = make_vec_env(rd.ENV_ID, n_envs=1, seed=args.seed + 1000, env_kwargs=env_kwargs)
    normalize = bool(hyperparams.get("normalize", False))
    if normalize:
        gamma = hyperparams.get("gamma", 0.99)
        env = VecNormalize(env, gamma=gamma)
        eval_env = VecNormalize(eval_env, gamma=gamma, training=False, norm_reward=False)

    algorithm = ALGORITHMS[args.algo]
    model = algorithm(
        hyperparams.get("policy", "MlpPolicy"),
        env,
        seed=args.seed,
        device="cpu",
        verbose=0,
        tensorboard_log=str(out / "tb"),
        **algorithm_kwargs(hyperparams),
    )
    callback = EvalCallback(
        eval_env,
        best_model_save_path=str(out),
        log_path=str(out / "eval"),
        eval_freq=max(1, 10_000 // n_envs),
        n_eval_episodes=10,
        deterministic=True,
        verbose=0,
    )
    start = time.perf_counter()
    try:
        model.learn(total_timesteps=timesteps, callback=callback, progress_bar=True, tb_log_name=args.algo)
    except KeyboardInterrupt:
        print("\ninterrupted: saving the model trained so far")
    minutes = (time.perf_counter() - start) / 60
    model.save(out / "model.zip")
    if normalize:
        env.save(str(out / "vecnormalize.pkl"))

    trained = NormalizedPolicy(model, env if normalize else None)
    results = [
        evaluate(
            trained, f"{args.algo.upper()} (trained, {model.num_timesteps} steps)", args.eval_episodes, **env_kwargs
        ),
        evaluate(PassiveAgent(), "passive disk (zero torque)", args.eval_episodes, **env_kwargs),
        evaluate(
            BASELINES[args.task](**env_kwargs),
            f"baseline: {BASELINES[args.task].__name__}",
            args.eval_episodes,
            **env_kwargs,
        ),
    ]
    lines = [
        f"# {args.task}: {args.algo.upper()}, seed {args.seed}, {model.num_timesteps} steps in {minutes:.1f} min",
        "",
        f"{args.eval_episodes} evaluation episodes (seeds {EVAL_SEED} to {EVAL_SEED + args.eval_episodes - 1}),"
        " deterministic actions.",
        "",
        "| agent | return (mean +- std) | success |",
        "|---|---|---|",
        *("| " + " | ".join(result.row()) + " |" for result in results),
    ]
    (out / "results.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return {result.name: result for result in results}


if __name__ == "__main__":
    main()
