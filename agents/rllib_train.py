"""PPO on RLlib (new API stack) with env runners stepping the native vector env, here or on a Ray cluster.

    python -m agents.rllib_train --task upright --env-runners 2 --envs-per-runner 8
    python -m agents.rllib_train --address auto --env-runners 32 --envs-per-runner 64   # README: "Beyond one machine"
    python -m agents.rllib_train --restore runs/rllib_upright_0/checkpoint --iterations 20   # train on
    python -m agents.rllib_train --restore runs/rllib_upright_0/checkpoint --iterations 0    # evaluate only

Needs ``pip install torch==2.13.0 -e ".[rllib]"`` (which pins gymnasium 1.2.2). Without ``--address`` it starts an
embedded Ray on this machine. Each of the ``--env-runners`` Ray actors (one CPU each) steps one
:class:`rolling_disk_env.RollingDiskVectorEnv` of ``--envs-per-runner`` disks, made by ``gym.make_vec`` in the
``vector_entry_point`` mode (one compiled batch, no loop over sub-envs), and runs the policy on the whole batch; the
learner runs in this process, on the CPU.

Hyperparameters are those of the task's block in ``agents/hyperparams/ppo.yml`` (SB3's PPO), under RLlib's names
(:data:`RLLIB_NAMES`): an iteration collects ``n_steps`` steps from every sub-env, as an SB3 rollout does, and
runs ``n_epochs`` epochs of minibatches of ``batch_size``, or of the iteration's whole batch where it is smaller
(RLlib refuses a minibatch larger than its train batch: ``upright``'s 1024 against 8 disks x 64 steps by default; the
run says so); ``policy_kwargs`` gives the hidden layers and their activation, for separate policy and value networks
with a state-independent log std as in SB3. Not carried over: ``normalize`` (the observations are of order 1 without
it) and ``log_std_init``. The default ``--iterations`` make the block's ``n_timesteps``.

The run directory (``--out``) receives ``checkpoint/`` (the whole algorithm: ``--restore`` continues from it, and
:func:`load_policy` reads its policy without Ray) and ``results.md``: the seeded evaluation table of train.py
(:func:`agents.evaluate.evaluate` and :func:`agents.evaluate.results_table`) for the trained policy, the passive
disk and the task's classical baseline. Ctrl-C stops training and still saves and evaluates.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import rolling_disk_env as rd

RLLIB_NAMES = {
    "learning_rate": "lr",
    "gamma": "gamma",
    "gae_lambda": "lambda_",
    "ent_coef": "entropy_coeff",
    "clip_range": "clip_param",
    "vf_coef": "vf_loss_coeff",
    "max_grad_norm": "grad_clip",
    "n_epochs": "num_epochs",
    "batch_size": "minibatch_size",
}
"""SB3 PPO's hyperparameters (zoo block keys) and RLlib's ``PPOConfig.training`` arguments of the same meaning."""
SB3_DEFAULTS = {"gae_lambda": 0.95, "vf_coef": 0.5, "max_grad_norm": 0.5, "n_epochs": 10, "batch_size": 64}
"""SB3's defaults for the keys a block may leave out (RLlib's differ)."""
NOT_CARRIED_OVER = frozenset({"normalize", "policy", "n_timesteps", "n_envs", "n_steps", "env_kwargs"})
"""Block keys that are no ``training`` argument: read elsewhere (n_steps, n_timesteps, env_kwargs), replaced by
``--envs-per-runner`` (n_envs) or dropped (normalize, policy)."""
MODULE = Path("learner_group", "learner", "rl_module", "default_policy")
"""Where a checkpoint keeps the policy (the RLModule)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The flags, checked (argparse's error, exit status 2) before Ray or torch load."""
    parser = argparse.ArgumentParser(
        prog="python -m agents.rllib_train",
        description="PPO on RLlib over the native vector env (see the module docstring).",
    )
    parser.add_argument("--task", choices=sorted(rd.TASK_IDS), default="upright")
    parser.add_argument(
        "--iterations", type=_at_least(0), help="training iterations (default: the block's n_timesteps)"
    )
    parser.add_argument(
        "--env-runners", type=_at_least(0), default=1, help="remote env runners, one CPU each (0: sample here)"
    )
    parser.add_argument("--envs-per-runner", type=_at_least(1), default=8, help="disks in each runner's vector env")
    parser.add_argument("--address", help="an existing Ray cluster ('auto', or host:port); default: a local Ray")
    parser.add_argument("--seed", type=_at_least(0), default=0)
    parser.add_argument("--out", type=Path, help="run directory (default: runs/rllib_<task>_<seed>)")
    parser.add_argument("--restore", type=Path, help="a checkpoint directory to continue from")
    parser.add_argument("--eval-episodes", type=_at_least(1), default=100, help="seeded episodes of the final table")
    args = parser.parse_args(argv)
    if args.restore is not None and not (args.restore / "rllib_checkpoint.json").is_file():
        parser.error(f"--restore {args.restore} is no RLlib checkpoint (no rllib_checkpoint.json)")
    args.out = args.out or Path("runs") / f"rllib_{args.task}_{args.seed}"
    from agents.training import HYPERPARAMS, ConfigError, check_env_kwargs, load_hyperparams

    config = HYPERPARAMS / "ppo.yml"
    try:
        block = load_hyperparams(config, rd.TASK_IDS[args.task])
        args.training, args.model, args.n_steps = rllib_hyperparams(block)
        args.env_kwargs = check_env_kwargs(args.task, block)
    except ConfigError as error:
        parser.error(f"{config}: {error}")
    disks = max(1, args.env_runners) * args.envs_per_runner
    args.batch = args.n_steps * disks
    if args.training["minibatch_size"] > args.batch:
        print(
            f"rllib_train: minibatches of {args.batch} steps, the iteration's whole batch ({args.n_steps} steps x "
            f"{disks} disks), instead of the block's batch_size {args.training['minibatch_size']}"
        )
        args.training["minibatch_size"] = args.batch
    if args.iterations is None:
        args.iterations = math.ceil(float(block["n_timesteps"]) / args.batch)
    return args


def _at_least(minimum: int):
    def convert(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        return value

    convert.__name__ = "int"
    return convert


def rllib_hyperparams(block: dict) -> tuple[dict, dict, int]:
    """``PPOConfig.training`` arguments, ``DefaultModelConfig`` fields and ``n_steps`` of a zoo PPO block.

    Raises:
        ConfigError: a key RLlib has no counterpart for, a schedule, or an unreadable policy_kwargs.
    """
    from agents.training import ConfigError, parse_zoo_expression

    unknown = sorted(block.keys() - RLLIB_NAMES.keys() - NOT_CARRIED_OVER - {"policy_kwargs"})
    if unknown:
        raise ConfigError(f"no RLlib counterpart for {unknown}; known: {sorted(RLLIB_NAMES)}")
    values = {**SB3_DEFAULTS, **{key: block[key] for key in RLLIB_NAMES.keys() & block.keys()}}
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{key}: RLlib takes a number here, got {value!r}")
    training = {RLLIB_NAMES[key]: value for key, value in values.items()}
    # SB3's PPO clips no value loss and has no KL penalty; RLlib's defaults do both.
    training.update(vf_clip_param=math.inf, use_kl_loss=False)
    policy_kwargs = block.get("policy_kwargs") or {}
    if isinstance(policy_kwargs, str):
        policy_kwargs = parse_zoo_expression(policy_kwargs)
    model = {
        "fcnet_hiddens": list(policy_kwargs.get("net_arch", [64, 64])),
        "vf_share_layers": False,
        "free_log_std": True,
    }
    if "activation_fn" in policy_kwargs:
        model["fcnet_activation"] = policy_kwargs["activation_fn"].__name__
    return training, model, int(block.get("n_steps", 2048))


def ppo_config(args: argparse.Namespace):
    """RLlib's PPO configuration: the task's per-task id stepped as a native vector env by the env runners."""
    import gymnasium as gym
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    return (
        PPOConfig()
        # "package:id" makes every env runner import the package, which registers the id.
        .environment(f"rolling_disk_env:{rd.TASK_IDS[args.task]}", env_config=args.env_kwargs)
        .env_runners(
            num_env_runners=args.env_runners,
            num_envs_per_env_runner=args.envs_per_runner,
            gym_env_vectorize_mode=gym.VectorizeMode.VECTOR_ENTRY_POINT,
            rollout_fragment_length=args.n_steps,
        )
        .training(train_batch_size_per_learner=args.batch, **args.training)
        .rl_module(model_config=DefaultModelConfig(**args.model))
        .debugging(seed=args.seed)
    )


class RLlibPolicy:
    """An RLlib policy (RLModule) with SB3's ``predict``: the mean action, clipped to the action space."""

    def __init__(self, module):
        self.module = module

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        import torch
        from ray.rllib.core.columns import Columns

        with torch.no_grad():
            batch = {Columns.OBS: torch.as_tensor(np.asarray(observation, dtype=np.float32))}
            inputs = self.module.forward_inference(batch)[Columns.ACTION_DIST_INPUTS]
            action_dist = self.module.get_inference_action_dist_cls().from_logits(inputs)
            action = action_dist.to_deterministic().sample().numpy()
        return np.clip(action, -1.0, 1.0), None


def load_policy(checkpoint: Path) -> RLlibPolicy:
    """The policy of a checkpoint written by this module, without Ray running."""
    from ray.rllib.core.rl_module.rl_module import RLModule

    return RLlibPolicy(RLModule.from_checkpoint((checkpoint / MODULE).resolve()))


def evaluation(policy, task: str, episodes: int, name: str, **env_kwargs) -> list:
    """train.py's evaluation: the policy, the passive disk and the task's baseline on the same seeded episodes."""
    from agents.baselines import BASELINES
    from agents.evaluate import PassiveAgent, evaluate

    evaluated = {"task": task, **env_kwargs}
    baseline = BASELINES[task]
    return [
        evaluate(policy, name, episodes, **evaluated),
        evaluate(PassiveAgent(), "passive disk (zero torque)", episodes, **evaluated),
        evaluate(baseline(**evaluated), f"baseline: {baseline.__name__}", episodes, **evaluated),
    ]


def run(args: argparse.Namespace) -> dict:
    """Trains (or continues), checkpoints and evaluates.

    Returns:
        ``results`` (the evaluation: policy, passive disk, baseline), ``checkpoint``, ``iteration`` and ``steps``
        (counted from the start of training, restored ones included), ``throughput`` (env steps per second of each
        iteration, learning included) and ``env_runner_envs`` (the class of each env runner's env).
    """
    import ray

    from agents.evaluate import EVAL_SEED, results_table

    # "local": a new Ray of its own, even where `ray start` left a cluster (or its address file) behind.
    ray.init(address=args.address or "local", logging_level="WARNING")
    try:
        cpus = ray.cluster_resources().get("CPU", 0)
        if args.address is None and args.env_runners > cpus:
            print(
                f"python -m agents.rllib_train: error: --env-runners {args.env_runners} is more than the {cpus:g}"
                " CPUs here (one each)",
                file=sys.stderr,
            )
            sys.exit(2)
        algo = ppo_config(args).build_algo()
        if args.restore is not None:
            algo.restore_from_path(args.restore.resolve())
        envs = algo.env_runner_group.foreach_env_runner(
            lambda runner: type(runner.env.unwrapped).__name__, local_env_runner=args.env_runners == 0
        )
        print(
            f"{args.task}: PPO, {args.env_runners} remote env runner(s), each stepping {', '.join(sorted(set(envs)))}"
            f" of {args.envs_per_runner} envs; {args.batch} env steps per iteration"
        )
        throughput, steps, iteration, start = [], 0, 0, time.perf_counter()
        try:
            for _ in range(args.iterations):
                began = time.perf_counter()
                result = algo.train()
                seconds = time.perf_counter() - began
                sampled = result["env_runners"]["num_env_steps_sampled"]
                steps, iteration = int(result["num_env_steps_sampled_lifetime"]), result["training_iteration"]
                throughput.append(sampled / seconds)
                # "sample": an env runner's time to collect its share (a running mean); the rest is learning.
                print(
                    f"iteration {iteration}: {sampled} env steps in {seconds:.2f} s ({sampled / seconds:.0f}/s; "
                    f"sampling {result['env_runners'].get('sample', math.nan):.2f} s), {steps} in all, "
                    f"mean return {result['env_runners'].get('episode_return_mean', math.nan):.1f}",
                    flush=True,
                )
        except KeyboardInterrupt:
            print("\ninterrupted: saving and evaluating the policy trained so far", flush=True)
        minutes = (time.perf_counter() - start) / 60
        checkpoint = Path(algo.save_to_path((args.out / "checkpoint").resolve()))
        policy = RLlibPolicy(algo.get_module())
        algo.stop()
    finally:
        ray.shutdown()
    results = evaluation(policy, args.task, args.eval_episodes, "PPO (RLlib)", **args.env_kwargs)
    text = (
        f"# {args.task}: RLlib PPO, seed {args.seed}, {args.env_runners} env runner(s) x {args.envs_per_runner} "
        f"envs, {args.iterations} iterations in {minutes:.1f} min\n\n"
        f"{args.eval_episodes} evaluation episodes (seeds {EVAL_SEED} to {EVAL_SEED + args.eval_episodes - 1}),"
        f" deterministic actions.\n\n{results_table(results)}\n"
    )
    (args.out / "results.md").write_text(text)
    print(f"\n{text}\ncheckpoint: {checkpoint}")
    return {
        "results": results,
        "checkpoint": checkpoint,
        "iteration": iteration,
        "steps": steps,
        "throughput": throughput,
        "env_runner_envs": envs,
    }


def main(argv: list[str] | None = None) -> dict:
    return run(parse_args(argv))


if __name__ == "__main__":
    main()
