"""Train a Stable-Baselines3 agent on a task of rolling-disk-env (the project's main job).

Hyperparameters come from agents/hyperparams/<algo>.yml, rl-baselines3-zoo's format, in the block of the task's own
id (RollingDisk<Task>-v0: RollingDiskGoto-v0 for --task goto). The run directory (--out; by default
runs/<task>_<algo>_<seed>, numbered _2, _3, ... where a previous run is there) receives model.zip (the final model,
which the results table evaluates), best_model.zip (the best periodic evaluation, with best_vecnormalize.pkl),
vecnormalize.pkl, config.yml (the hyperparameters used), command.txt, TensorBoard logs in tb/ (tensorboard --logdir
runs/) and results.md: mean +- std return and success rate over seeded evaluation episodes of the trained agent, the
passive disk and the task's classical baseline. Ctrl-C stops training and still saves and evaluates the model.

With --device (cuda or cpu), rsl-rl-lib's PPO trains instead, on the torch vector env with the disks and the policy
on that device (agents/hyperparams/rsl_rl_ppo.yml, the [gpu] extra): the run directory holds model.pt (rsl_rl's
checkpoint) and policy.pt2 (torch.export's program) instead of the .zip files, and the same table.

With --jax, rejax's PPO trains on the task's gymnax env (rolling_disk_env.jax), the env, the rollouts and the updates
compiled into one XLA program (agents/hyperparams/rejax_ppo.yml, the [jax] extra): the run directory holds
policy.msgpack and timings.md (compile and training time) instead of the .zip files, and the same table, evaluated
on the Gymnasium env.

examples:
  python train.py                                   # PPO on task upright: the README's main job
  python train.py --task circle                     # PPO on task circle
  python train.py --task circle --algo sac --timesteps 200000 --seed 3 --out runs/circle_sac
  python train.py --verbose 1                       # SB3's training logs too
  python train.py --device cuda                     # rsl_rl's PPO on the GPU, 4096 disks (the [gpu] extra)
  python train.py --jax                             # rejax's PPO on the JAX env, one XLA program (the [jax] extra)
  python -m agents.evaluate --model runs/upright_ppo_0/model.zip --render human   # watch the trained agent
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

# Only the standard library is imported before the arguments are parsed: --help and argument errors answer at
# once, and torch, SB3 and the package load (seconds) only for a run.
TASKS = ("upright", "circle", "goto", "waypoints", "eight", "recovery", "recovery_sparse", "ice")
"""The tasks with hyperparameters, keys of ``rolling_disk_env.TASK_IDS`` (tests/test_train_cli.py checks both)."""
ALGORITHMS = ("ppo", "sac", "td3")
"""The algorithms, the keys of ``agents.evaluate.ALGORITHMS`` (checked likewise)."""
HYPERPARAMS = Path(__file__).parent / "agents" / "hyperparams"
DEVICES = ("cpu", "cuda")
"""The devices of --device (``rolling_disk_env.envs.torch_vector.DEVICES``)."""


def integer_from(minimum: int):
    """argparse type: an integer >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {text!r}")
        return value

    return parse


positive_int = integer_from(1)
seed = integer_from(0)
"""numpy's seeds: integers >= 0."""


def existing_file(text: str) -> Path:
    """argparse type: the path of an existing file."""
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return path


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the docstring's layout and shows each option's default once: its value where it has one and its help does
    not say it already, never for a flag."""

    def _get_help_string(self, action: argparse.Action) -> str:
        flag = isinstance(action, argparse._StoreTrueAction)
        if action.default not in (None, argparse.SUPPRESS) and "default" not in action.help and not flag:
            return f"{action.help} (default: %(default)s)"
        return action.help


def parser() -> argparse.ArgumentParser:
    description, _, examples = __doc__.partition("examples:")
    parser = argparse.ArgumentParser(
        prog="python train.py", description=description, epilog="examples:" + examples, formatter_class=HelpFormatter
    )
    parser.add_argument("--task", choices=TASKS, default="upright", help="the task")
    parser.add_argument("--algo", choices=ALGORITHMS, default="ppo", help="the SB3 algorithm")
    parser.add_argument(
        "--timesteps", type=positive_int, metavar="N", help="environment steps (default: the config's n_timesteps)"
    )
    parser.add_argument(
        "--n-envs", type=positive_int, metavar="N", help="training environments (default: the config's n_envs)"
    )
    parser.add_argument("--seed", type=seed, default=0, help="seed of the model and the training environments")
    parser.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help="run directory, new or empty (default: runs/<task>_<algo>_<seed>, numbered where a previous run is there)",
    )
    parser.add_argument(
        "--config",
        type=existing_file,
        metavar="FILE",
        help="hyperparameters, zoo format (default: agents/hyperparams/<algo>.yml)",
    )
    parser.add_argument(
        "--eval-episodes", type=positive_int, default=100, metavar="N", help="seeded episodes of the final table"
    )
    parser.add_argument("--threads", type=positive_int, default=1, metavar="N", help="torch CPU threads")
    parser.add_argument(
        "--device",
        choices=DEVICES,
        help="train rsl_rl's PPO with the disks and the policy on this device (default: SB3 on the CPU engine)",
    )
    parser.add_argument(
        "--jax",
        action="store_true",
        help="train rejax's PPO on the JAX env, compiled with it into one XLA program (default: SB3 on the CPU engine)",
    )
    parser.add_argument(
        "--verbose", type=int, choices=(0, 1, 2), default=0, help="SB3's output: 1 training logs, 2 debug"
    )
    return parser


RUN_FILES = ("results.md", "model.zip", "model.pt", "policy.pt2", "policy.msgpack")
"""What a finished or interrupted run leaves in its directory, by trainer."""


def holds_a_run(directory: Path) -> bool:
    """Whether ``directory`` holds a previous run's results or model."""
    return any((directory / name).exists() for name in RUN_FILES)


def new_run_directory(first: Path) -> Path:
    """``first``, or where a previous run is there, the first of ``first_2``, ``first_3``, ... that holds none (as
    rl-baselines3-zoo numbers its runs)."""
    directory, number = first, 1
    while holds_a_run(directory):
        number += 1
        directory = first.with_name(f"{first.name}_{number}")
    return directory


def main(argv: list[str] | None = None) -> list:
    """Parses ``argv`` (default: the command line), trains, prints the results table; returns the results
    (``agents.evaluate.Result``: trained agent, passive disk, baseline)."""
    arguments = parser()
    args = arguments.parse_args(argv)
    from agents import show_compiling

    show_compiling()

    if args.device is not None and args.algo != "ppo":
        arguments.error(f"--device trains PPO (rsl_rl's), not {args.algo}")
    if args.jax and (args.algo != "ppo" or args.device is not None):
        arguments.error("--jax trains PPO (rejax's) on the CPU JAX finds, without --device or another --algo")
    if args.out is not None and holds_a_run(args.out):
        arguments.error(f"--out {args.out} holds a previous run (its results or a model): choose another --out")
    name = f"rsl_rl_{args.device}" if args.device else "rejax_ppo" if args.jax else args.algo
    out = args.out or new_run_directory(Path("runs") / f"{args.task}_{name}_{args.seed}")
    import rolling_disk_env as rd
    from agents.training import ConfigError, load_hyperparams, train

    config = args.config or HYPERPARAMS / f"{'rsl_rl_ppo' if args.device else name}.yml"
    try:
        hyperparams = load_hyperparams(config, rd.TASK_IDS[args.task])
    except (OSError, ConfigError) as error:
        sys.exit(f"train.py: error: {error}")
    print(f"run directory: {out}", flush=True)
    try:
        common = {
            "timesteps": args.timesteps,
            "n_envs": args.n_envs,
            "seed": args.seed,
            "eval_episodes": args.eval_episodes,
            "threads": args.threads,
            "verbose": args.verbose,
        }
        if args.device is not None:
            results = _train_on_device(args.task, args.device, hyperparams, out, common)
        elif args.jax:
            results = _train_in_jax(args.task, hyperparams, out, common)
        else:
            results = train(args.task, args.algo, hyperparams, out, **common)
    except ConfigError as error:
        sys.exit(f"train.py: error: {config}: {error}")
    except KeyboardInterrupt:
        print(f"\ninterrupted; run directory: {out}", file=sys.stderr)
        sys.exit(130)
    print((out / "results.md").read_text(), end="")
    print(f"run directory: {out}")
    return results


def _train_on_device(task: str, device: str, hyperparams: dict, out: Path, common: dict) -> list:
    """``--device``: rsl_rl's PPO (``agents.device_training``), with a clear exit where its extra is missing."""
    try:
        from agents.device_training import train_on_device
    except ImportError as error:
        sys.exit(f"train.py: error: {error}")
    try:
        return train_on_device(task, hyperparams, out, device=device, **common)
    except (ImportError, RuntimeError) as error:
        if not str(error).startswith(("device=", "train.py --device")):  # not a missing extra, GPU or driver
            raise
        sys.exit(f"train.py: error: {error}")


def _train_in_jax(task: str, hyperparams: dict, out: Path, common: dict) -> list:
    """``--jax``: rejax's PPO (``agents.jax_training``), with a clear exit where its extra is missing."""
    try:
        from agents.jax_training import train_in_jax
    except ImportError as error:
        sys.exit(f"train.py: error: {error}")
    return train_in_jax(task, hyperparams, out, **common)


if __name__ == "__main__":
    main()
