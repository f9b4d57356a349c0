"""Hyperparameter sweeps on Ray Tune: train.py's training, many times, on this machine or on a Ray cluster.

    python -m agents.sweep --task upright --algo ppo --samples 16 --timesteps 100000
    python -m agents.sweep --samples 64 --address auto      # on a running cluster (README: "Beyond one machine")

Needs ``pip install torch==2.13.0 -e ".[ray]"``. Without ``--address`` the sweep starts an embedded Ray on this
machine and stops it at the end. Every trial calls :func:`agents.training.train` (what ``train.py`` runs) with the
task's block of ``agents/hyperparams/<algo>.yml`` updated by values drawn from the search space, in its own trial
directory under ``--out`` (``model.zip``, ``best_model.zip``, ``vecnormalize.pkl``, TensorBoard logs,
``results.md``), with ``--cpus-per-trial`` CPUs and as many torch threads. A trial reports to Tune the mean return
and success rate of each periodic evaluation (every 10,000 steps, 10 episodes) and, once trained, of the final
evaluation (100 seeded episodes, train.py's table). The ASHA scheduler (``--scheduler asha``, the default) stops a
trial at a rung (``--grace-period`` steps, then 3, 9, ... times that, below ``--timesteps``) when its return is below
two thirds of the trials that reached that rung before it; ``--scheduler fifo`` runs every trial to the end.

The sweep ends by printing the trials best first (status, return, success, steps, time, sampled values), writing the
table to ``OUT/trials.csv`` and the best finished trial's block to ``OUT/best.yml``, which ``python train.py --task
<task> --algo <algo> --config OUT/best.yml`` trains again. Ctrl-C stops the running trials and keeps the finished
ones; the same command then resumes the sweep in ``OUT`` (Tune's restore: unfinished trials start again).

Search space (``--search FILE``, default ``agents/sweeps/<algo>.yml``): a YAML mapping whose keys are keys of the
task's block (``learning_rate``, ``n_steps``, ...) or ``policy_kwargs.<name>``, one argument inside the block's
``policy_kwargs`` string (``policy_kwargs.net_arch``), and whose values are

- ``{<sampler>: [arguments]}``: Ray Tune's ``tune.<sampler>(*arguments)``, one of ``uniform``, ``quniform``,
  ``loguniform``, ``qloguniform``, ``randint``, ``qrandint``, ``lograndint``, ``qlograndint``, ``randn``,
  ``qrandn`` (``{loguniform: [1.0e-5, 1.0e-3]}``);
- ``{choice: [values]}``: one of the values at random (``{choice: [[64, 64], [256, 256]]}``);
- ``{grid_search: [values]}``: every value, each in ``--samples`` trials;
- anything else: a value every trial takes.
"""

from __future__ import annotations

import argparse
import ast
import csv
import json
import logging
import math
import sys
from pathlib import Path

import yaml

import rolling_disk_env as rd

AGENTS = Path(__file__).parent
SEARCH_SPACES = AGENTS / "sweeps"
"""The default search space of each algorithm: ``<algo>.yml``."""
SAMPLERS = frozenset(
    {"uniform", "quniform", "loguniform", "qloguniform", "randint", "qrandint", "lograndint", "qlograndint", "randn"}
    | {"qrandn", "choice", "grid_search"}
)
"""The Ray Tune samplers a search space may name."""
POLICY_KWARGS = "policy_kwargs."
"""The prefix of a search key that sets one argument inside the block's ``policy_kwargs``."""
EXPERIMENT = "tune"
"""The Tune experiment's folder inside ``--out`` (the trial directories and Tune's state, for resuming)."""
REDUCTION_FACTOR = 3
"""ASHA keeps the best third of the trials at each rung; rungs are this factor apart."""
COLUMNS = ("trial", "status", "return", "success", "steps", "time_s")
"""The columns of ``trials.csv`` before the sampled hyperparameters."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The sweep's flags, checked (argparse's error and exit status 2 for a bad one) before Ray or torch load."""
    parser = argparse.ArgumentParser(
        prog="python -m agents.sweep",
        description="A Ray Tune hyperparameter sweep of train.py's training (see the module docstring).",
    )
    algos = sorted(path.stem for path in SEARCH_SPACES.glob("*.yml"))
    parser.add_argument("--task", choices=sorted(rd.TASK_IDS), default="upright")
    parser.add_argument("--algo", choices=algos, default="ppo")
    parser.add_argument("--samples", type=_positive(int), default=8, help="trials (per grid point; default 8)")
    parser.add_argument("--timesteps", type=_positive(int), help="steps per trial (default: the block's n_timesteps)")
    parser.add_argument("--search", type=Path, help="search space YAML (default: agents/sweeps/<algo>.yml)")
    parser.add_argument("--scheduler", choices=("asha", "fifo"), default="asha")
    parser.add_argument(
        "--grace-period", type=_positive(int), help="steps before ASHA's first rung (default: a tenth of --timesteps)"
    )
    parser.add_argument("--cpus-per-trial", type=_positive(float), default=1.0, help="CPUs (and torch threads)")
    parser.add_argument("--address", help="an existing Ray cluster ('auto', or host:port); default: a local Ray")
    parser.add_argument(
        "--seed", type=_positive(int, minimum=0), default=0, help="seeds the sampling and every trial (default 0)"
    )
    parser.add_argument("--out", type=Path, help="sweep directory (default: runs/sweep_<task>_<algo>)")
    args = parser.parse_args(argv)
    args.search = args.search or SEARCH_SPACES / f"{args.algo}.yml"
    args.out = args.out or Path("runs") / f"sweep_{args.task}_{args.algo}"
    try:
        args.space = load_search_space(args.search)
    except (OSError, ValueError) as error:
        parser.error(str(error))
    from agents.training import HYPERPARAMS, ConfigError, algorithm_kwargs, load_hyperparams

    try:
        args.block = load_hyperparams(HYPERPARAMS / f"{args.algo}.yml", rd.TASK_IDS[args.task])
        algorithm_kwargs(args.algo, apply_sample(args.block, first_values(args.space)))
    except (ConfigError, ValueError) as error:
        parser.error(f"{args.search}: {error}")
    args.timesteps = args.timesteps or int(args.block["n_timesteps"])
    args.grace_period = args.grace_period or max(1, args.timesteps // 10)
    if args.grace_period > args.timesteps:
        parser.error(f"--grace-period {args.grace_period} is more than --timesteps {args.timesteps}")
    return args


def _positive(kind, minimum=None):
    """argparse type: a finite number of ``kind`` above 0, or at least ``minimum``."""

    def convert(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if minimum is None and not (value > 0 and math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"must be positive, got {text}")
        if minimum is not None and value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {text}")
        return value

    convert.__name__ = kind.__name__
    return convert


def load_search_space(path: Path) -> dict:
    """The search space in ``path`` as written: ``{key: {sampler: arguments} or value}``.

    Raises:
        OSError: the file cannot be read.
        ValueError: not a mapping of hyperparameters, or a sampler that does not exist or has no argument list.
    """
    try:
        space = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ValueError(f"{path} is not valid YAML: {error}") from None
    if not isinstance(space, dict) or not space:
        raise ValueError(f"{path} must map hyperparameters to samplers such as {{loguniform: [1.0e-5, 1.0e-3]}}")
    for key, value in space.items():
        if not isinstance(key, str) or key in {POLICY_KWARGS, "policy_kwargs", "env_kwargs", "n_timesteps"}:
            raise ValueError(
                f"{path}: {key!r} cannot be searched (n_timesteps is --timesteps; use policy_kwargs.<name>)"
            )
        if isinstance(value, dict) and len(value) == 1:
            (sampler, arguments), *_ = value.items()
            if sampler not in SAMPLERS:
                raise ValueError(f"{path}: {key}: unknown sampler {sampler!r}; samplers: {sorted(SAMPLERS)}")
            if not isinstance(arguments, list) or not arguments:
                raise ValueError(f"{path}: {key}: {sampler} needs a list of arguments, got {arguments!r}")
    return space


def _sampler(value) -> tuple[str, list] | None:
    """``(sampler, arguments)`` of a search space's value, None for a value every trial takes."""
    if isinstance(value, dict) and len(value) == 1 and next(iter(value)) in SAMPLERS:
        return next(iter(value.items()))
    return None


def tune_space(space: dict) -> dict:
    """Ray Tune's ``param_space`` of a search space: samplers become Tune's domains, other values stay."""
    from ray import tune

    def domain(value):
        sampler = _sampler(value)
        if sampler is None:
            return value
        name, arguments = sampler
        return getattr(tune, name)(arguments) if name in ("choice", "grid_search") else getattr(tune, name)(*arguments)

    return {key: domain(value) for key, value in space.items()}


def expected_trials(space: dict, samples: int) -> int:
    """Trials in a sweep: ``samples`` for each point of the grid (the product of the grid_search lists)."""
    for value in space.values():
        sampler = _sampler(value)
        if sampler is not None and sampler[0] == "grid_search":
            samples *= len(sampler[1])
    return samples


def first_values(space: dict) -> dict:
    """One value per key of a search space, its first argument (to check keys and values before Ray starts)."""
    return {key: value if _sampler(value) is None else _sampler(value)[1][0] for key, value in space.items()}


def apply_sample(block: dict, sample: dict) -> dict:
    """The zoo block updated with one trial's sampled values (``policy_kwargs.<name>`` edits inside
    ``policy_kwargs``, keeping the zoo's string form); ``block`` is not modified."""
    updated = dict(block)
    for key, value in sample.items():
        value = _plain(value)
        if key.startswith(POLICY_KWARGS):
            updated["policy_kwargs"] = _set_argument(updated.get("policy_kwargs"), key[len(POLICY_KWARGS) :], value)
        else:
            updated[key] = value
    return updated


def _plain(value):
    """Python scalars and lists of a sampled value (Tune may hand numpy scalars), as YAML writes them."""
    if hasattr(value, "item") and not isinstance(value, (list, tuple)):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    return value


def _set_argument(policy_kwargs, name: str, value):
    """``policy_kwargs`` (a zoo string ``"dict(...)"``, a mapping or None) with ``name`` set to ``value``."""
    if policy_kwargs is None:
        policy_kwargs = "dict()"
    if isinstance(policy_kwargs, dict):
        return {**policy_kwargs, name: value}
    try:
        call = ast.parse(policy_kwargs.strip(), mode="eval").body
    except SyntaxError:
        call = None
    if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id == "dict"):
        raise ValueError(f"policy_kwargs {policy_kwargs!r} is not a dict(...) to set {name} in")
    argument = ast.parse(repr(value), mode="eval").body
    names = [keyword.arg for keyword in call.keywords]
    if name in names:
        call.keywords[names.index(name)].value = argument
    else:
        call.keywords.append(ast.keyword(name, argument))
    return ast.unparse(call)


def trial(
    config: dict, *, task: str, algo: str, block: dict, timesteps: int, seed: int, threads: int, experiment: str
) -> None:
    """One Tune trial: :func:`agents.training.train` in the trial's directory of ``experiment`` (written there
    directly, so that it fills up while the trial runs), reporting every evaluation."""
    from ray import tune
    from stable_baselines3.common.save_util import load_from_zip_file

    from agents.training import train

    out = Path(experiment, trial_dirname(tune.get_context()))

    def report(num_timesteps: int, mean_return: float, success_rate: float) -> None:
        tune.report({"timesteps": num_timesteps, "return": mean_return, "success": success_rate})

    trained, *_ = train(
        task,
        algo,
        apply_sample(block, config),
        out,
        timesteps=timesteps,
        seed=seed,
        threads=threads,
        progress_bar=False,
        on_evaluation=report,
    )
    data, _, _ = load_from_zip_file(out / "model.zip", device="cpu")
    tune.report(
        {
            "timesteps": int(data["num_timesteps"]),
            "return": float(trained.returns.mean()),
            "success": float(trained.successes.mean()),
            "final": True,
        }
    )


def trial_dirname(trial) -> str:
    """The directory name of a trial (Tune's ``Trial``, or the ``TuneContext`` inside it): ``trial_<id>``."""
    trial_id = trial.get_trial_id() if hasattr(trial, "get_trial_id") else trial.trial_id
    return f"trial_{trial_id}"


def run(args: argparse.Namespace) -> int:
    """Runs (or resumes) the sweep of ``args`` and reports it; the exit status (130 when interrupted)."""
    import ray
    from ray import tune
    from ray.tune.schedulers import ASHAScheduler, FIFOScheduler
    from ray.tune.search import BasicVariantGenerator

    settings = {
        "task": args.task,
        "algo": args.algo,
        "samples": args.samples,
        "timesteps": args.timesteps,
        "scheduler": args.scheduler,
        "grace_period": args.grace_period,
        "seed": args.seed,
        "search": args.space,
    }
    out = args.out.resolve()
    experiment = out / EXPERIMENT
    settings_file = out / "sweep.json"
    resuming = settings_file.exists()
    if resuming and json.loads(settings_file.read_text()) != settings:
        print(
            f"python -m agents.sweep: error: {args.out} holds a sweep with other settings ({settings_file}); "
            "give the same flags to resume it, or another --out",
            file=sys.stderr,
        )
        return 2
    out.mkdir(parents=True, exist_ok=True)
    settings_file.write_text(json.dumps(settings, indent=2) + "\n")

    # "local": a new Ray of its own, even where `ray start` left a cluster (or its address file) behind.
    ray.init(address=args.address or "local", runtime_env={"py_modules": [str(AGENTS)]}, logging_level="WARNING")
    try:
        cpus = ray.cluster_resources().get("CPU", 0)
        if args.address is None and args.cpus_per_trial > cpus:
            print(
                f"python -m agents.sweep: error: --cpus-per-trial {args.cpus_per_trial:g} is more than the {cpus:g}"
                " CPUs here",
                file=sys.stderr,
            )
            return 2
        trainable = tune.with_resources(
            tune.with_parameters(
                trial,
                task=args.task,
                algo=args.algo,
                block=args.block,
                experiment=str(experiment),
                timesteps=args.timesteps,
                seed=args.seed,
                threads=max(1, int(args.cpus_per_trial)),
            ),
            {"cpu": args.cpus_per_trial},
        )
        if resuming and tune.Tuner.can_restore(str(experiment)):
            print(f"resuming the sweep in {args.out}")
            tuner = tune.Tuner.restore(str(experiment), trainable, resume_unfinished=True, restart_errored=True)
        else:
            if args.scheduler == "asha":
                scheduler = ASHAScheduler(
                    time_attr="timesteps",
                    max_t=args.timesteps,
                    grace_period=args.grace_period,
                    reduction_factor=REDUCTION_FACTOR,
                    # A trial's last periodic evaluation may come at max_t; it must still reach its final one.
                    stop_last_trials=False,
                )
            else:
                scheduler = FIFOScheduler()
            tuner = tune.Tuner(
                trainable,
                param_space=tune_space(args.space),
                tune_config=tune.TuneConfig(
                    metric="return",
                    mode="max",
                    num_samples=args.samples,
                    search_alg=BasicVariantGenerator(random_state=args.seed),
                    scheduler=scheduler,
                    trial_dirname_creator=trial_dirname,
                ),
                run_config=tune.RunConfig(name=EXPERIMENT, storage_path=str(out), verbose=1),
            )
        tuner.fit()
        # Trials that reported nothing before an interruption make ExperimentAnalysis warn; the table says so.
        logging.getLogger("ray.tune.analysis.experiment_analysis").setLevel(logging.ERROR)
        trials = tune.ExperimentAnalysis(str(experiment)).trials
    finally:
        ray.shutdown()
    return summarize(trials, args)


def trial_rows(trials, keys: list[str]) -> list[dict]:
    """One row per trial, best first: status, last reported return, success, steps, time and sampled values."""
    rows = []
    for item in trials:
        result = item.last_result or {}
        if item.status == "TERMINATED":
            status = "done" if result.get("final") else "stopped early"
        else:
            status = "error" if item.status == "ERROR" else "unfinished"
        rows.append(
            {
                "trial": Path(item.path).name,
                "status": status,
                "return": result.get("return", math.nan),
                "success": result.get("success", math.nan),
                "steps": result.get("timesteps", 0),
                "time_s": result.get("time_total_s", 0.0),
                **{key: _plain(item.config.get(key)) for key in keys},
            }
        )

    def rank(row: dict):
        value = row["return"]
        return (row["status"] != "done", -value if math.isfinite(value) else math.inf)

    return sorted(rows, key=rank)


def markdown_table(rows: list[dict], keys: list[str]) -> str:
    """The trials as a markdown table, best first."""
    lines = [
        "| # | trial | status | return | success | steps | time | " + " | ".join(keys) + " |",
        "|---" * (7 + len(keys)) + "|",
    ]
    for number, row in enumerate(rows, 1):
        cells = [
            str(number),
            row["trial"],
            row["status"],
            f"{row['return']:.1f}",
            f"{100 * row['success']:.0f}%" if math.isfinite(row["success"]) else "-",
            str(row["steps"]),
            f"{row['time_s']:.0f} s" if row["time_s"] < 120 else f"{row['time_s'] / 60:.1f} min",
            *(_format(row[key]) for key in keys),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _format(value) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)


def summarize(trials, args: argparse.Namespace) -> int:
    """Prints the trials best first, writes ``trials.csv`` and ``best.yml``; the exit status: 0, 130 for an
    unfinished sweep, 1 if a trial failed."""
    keys = list(args.space)
    rows = trial_rows(trials, keys)
    print(f"\n{len(rows)} trials, {args.task}, {args.algo.upper()}, {args.timesteps} steps each, best first:\n")
    print(markdown_table(rows, keys))
    table = args.out / "trials.csv"
    with open(table, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=[*COLUMNS, *keys])
        writer.writeheader()
        writer.writerows(rows)
    print(f"\nwrote {table}")
    best = next((row for row in rows if row["status"] == "done"), None)
    if best is not None:
        config = next(item.config for item in trials if Path(item.path).name == best["trial"])
        hyperparams = {**apply_sample(args.block, config), "n_timesteps": args.timesteps}
        path = args.out / "best.yml"
        path.write_text(
            f"# The best trial ({best['trial']}, return {best['return']:.1f}) of the sweep in {args.out}, in\n"
            f"# rl-baselines3-zoo's format: python train.py --task {args.task} --algo {args.algo} --config {path}\n"
            + yaml.safe_dump({rd.TASK_IDS[args.task]: hyperparams}, sort_keys=False)
        )
        print(f"wrote {path}")
    if any(row["status"] == "unfinished" for row in rows) or len(rows) < expected_trials(args.space, args.samples):
        print(f"\nthe sweep is unfinished: the same command resumes it from {args.out}")
        return 130
    failed = [row["trial"] for row in rows if row["status"] == "error"]
    if failed:
        print(f"\n{len(failed)} trial(s) failed: see error.txt in {', '.join(failed)} under {args.out / EXPERIMENT}")
        return 1
    return 0


def main(argv: list[str] | None = None) -> int:
    return run(parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
