"""Training one Stable-Baselines3 agent on a task of rolling-disk-env: what ``train.py`` and the Ray Tune sweeps run.

Hyperparameters are blocks of rl-baselines3-zoo's YAML files (``agents/hyperparams/<algo>.yml``), keyed by the
per-task env ids (:data:`rolling_disk_env.TASK_IDS`). :func:`train` reads a block as rl_zoo3's ``train`` does:
``n_timesteps``, ``n_envs``, ``normalize`` (VecNormalize with the block's ``gamma``), ``env_kwargs``, ``policy``,
schedules written ``lin_<initial value>`` and ``policy_kwargs`` in the zoo's string form, which is read here without
``eval`` (:func:`parse_zoo_expression`); every other key goes to the SB3 algorithm.
"""

from __future__ import annotations

import ast
import inspect
import math
import shlex
import sys
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
import yaml
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import VecNormalize
from torch import nn
from tqdm import tqdm

import rolling_disk_env as rd
from agents.baselines import BASELINES
from agents.evaluate import ALGORITHMS, EVAL_SEED, NormalizedPolicy, PassiveAgent, Result, evaluate, results_table
from rolling_disk_env.sb3 import make_vec_env as native_vec_env

HYPERPARAMS = Path(__file__).parent / "hyperparams"
"""The zoo-format hyperparameter files, one per algorithm: ``<algo>.yml``."""
ACTIVATIONS = ("ELU", "LeakyReLU", "ReLU", "Tanh")
"""The ``torch.nn`` activations a zoo expression may name, written ``nn.<name>``."""
ZOO_KEYS = frozenset({"n_timesteps", "n_envs", "normalize", "env_kwargs", "policy"})
"""The keys of a block that :func:`train` reads itself; the others are the SB3 algorithm's arguments."""
SCHEDULES = ("learning_rate", "clip_range", "clip_range_vf")
"""The arguments that may be a linear schedule ``lin_<initial value>``."""
EVAL_EVERY = 10_000
"""Environment steps between two periodic evaluations (:class:`PeriodicEvaluation`) during training."""
EVAL_DURING_TRAINING = 10
"""Episodes of each periodic evaluation (run at once on the native vector env)."""


class ConfigError(ValueError):
    """A hyperparameter file or block that cannot be used; the message names the file or key and what is wrong."""


def load_hyperparams(path: Path, env_id: str) -> dict:
    """The block ``env_id`` of the zoo-format YAML file ``path``, as written (strings unparsed).

    Raises:
        FileNotFoundError: no file at ``path``.
        ConfigError: the file is no YAML mapping or has no block ``env_id``.
    """
    with open(path) as handle:
        try:
            blocks = yaml.safe_load(handle)
        except yaml.YAMLError as error:
            raise ConfigError(f"{path} is not valid YAML: {error}") from None
    if not isinstance(blocks, dict):
        raise ConfigError(f"{path} must map env ids to hyperparameter blocks")
    if env_id not in blocks:
        raise ConfigError(f"{path} has no block {env_id!r}; blocks: {sorted(blocks)}")
    if not isinstance(blocks[env_id], dict):
        raise ConfigError(f"{path}: block {env_id!r} must be a mapping of hyperparameters")
    return dict(blocks[env_id])


def parse_zoo_expression(text: str, key: str = "policy_kwargs"):
    """The value of a zoo string such as ``"dict(net_arch=[64, 64], activation_fn=nn.Tanh)"``, without ``eval``.

    Accepted: numbers, strings, True, False, None, lists, tuples, ``{...}`` with string keys, ``dict(name=value,
    ...)`` and the activations ``nn.ELU``, ``nn.LeakyReLU``, ``nn.ReLU``, ``nn.Tanh`` (the classes).

    Raises:
        ConfigError: anything else, named, with ``key`` (the hyperparameter the string belongs to).
    """
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as error:
        raise ConfigError(f"{key}: {text!r} is not a Python expression ({error.msg})") from None
    return _literal(tree.body, key)


def _literal(node: ast.expr, key: str):
    if isinstance(node, ast.Constant) and (node.value is None or isinstance(node.value, (bool, int, float, str))):
        return node.value
    if (
        isinstance(node, ast.UnaryOp)
        and isinstance(node.op, ast.USub)
        and isinstance(node.operand, ast.Constant)
        and type(node.operand.value) in (int, float)
    ):
        return -node.operand.value
    if isinstance(node, (ast.List, ast.Tuple)):
        items = [_literal(item, key) for item in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    if isinstance(node, ast.Dict) and all(isinstance(k, ast.Constant) and isinstance(k.value, str) for k in node.keys):
        return {k.value: _literal(v, key) for k, v in zip(node.keys, node.values)}
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id == "dict"
        and not node.args
        and all(keyword.arg is not None for keyword in node.keywords)
    ):
        return {keyword.arg: _literal(keyword.value, key) for keyword in node.keywords}
    if (
        isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id == "nn"
        and node.attr in ACTIVATIONS
    ):
        return getattr(nn, node.attr)
    raise ConfigError(
        f"{key}: {ast.unparse(node)!r} is not allowed; use numbers, strings, True/False/None, lists, "
        f"dict(name=value, ...) and the activations {', '.join('nn.' + name for name in ACTIVATIONS)}"
    )


def algorithm_kwargs(algo: str, hyperparams: dict) -> dict:
    """The SB3 keyword arguments of a zoo block: every key but :data:`ZOO_KEYS`, with ``policy_kwargs`` parsed and
    ``lin_<x>`` schedules turned into linear schedules from x to 0.

    Raises:
        ConfigError: a key that is not an argument of the algorithm, or a value it cannot read.
    """
    algorithm = ALGORITHMS[algo]
    accepted = set(inspect.signature(algorithm).parameters) - {"policy", "env"}
    kwargs = {key: value for key, value in hyperparams.items() if key not in ZOO_KEYS}
    unknown = sorted(kwargs.keys() - accepted)
    if unknown:
        raise ConfigError(
            f"unknown hyperparameter(s) {unknown} for {algo}: neither keys train.py reads ({sorted(ZOO_KEYS)}) "
            f"nor arguments of {algorithm.__name__}"
        )
    policy_kwargs = kwargs.get("policy_kwargs")
    if isinstance(policy_kwargs, str):
        policy_kwargs = kwargs["policy_kwargs"] = parse_zoo_expression(policy_kwargs)
    if policy_kwargs is not None and not isinstance(policy_kwargs, dict):
        raise ConfigError(f"policy_kwargs must be a dict(...), got {policy_kwargs!r}")
    if isinstance((policy_kwargs or {}).get("activation_fn"), str):
        raise ConfigError(
            "policy_kwargs: activation_fn must be a class, not the string "
            f'{policy_kwargs["activation_fn"]!r}: write the zoo\'s form "dict(activation_fn=nn.Tanh, ...)"'
        )
    for key in SCHEDULES:
        value = kwargs.get(key)
        if isinstance(value, str):
            kind, _, initial = value.partition("_")
            try:
                start = float(initial)
            except ValueError:
                start = math.nan
            if kind != "lin" or not math.isfinite(start):
                raise ConfigError(f"{key}: {value!r} is neither a number nor a linear schedule 'lin_<value>'")
            kwargs[key] = LinearSchedule(start, 0.0, 1.0)
    if isinstance(kwargs.get("train_freq"), list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])
    return kwargs


def normalize_kwargs(hyperparams: dict) -> dict | None:
    """VecNormalize's keyword arguments from the block's ``normalize`` (a bool, a mapping or the zoo's string
    ``"dict(norm_obs=..., norm_reward=...)"``) and ``gamma``; None without normalization."""
    value = hyperparams.get("normalize", False)
    if isinstance(value, str):
        value = parse_zoo_expression(value, "normalize")
    if value is False:
        return None
    if value is True:
        value = {}
    if not isinstance(value, dict):
        raise ConfigError(f"normalize must be true, false or a dict(...) of VecNormalize arguments, got {value!r}")
    return {**value, **({"gamma": hyperparams["gamma"]} if "gamma" in hyperparams else {})}


def check_env_kwargs(task: str, hyperparams: dict) -> dict:
    """The block's ``env_kwargs`` (keyword arguments of the per-task id), checked by building one env."""
    env_kwargs = hyperparams.get("env_kwargs") or {}
    if not isinstance(env_kwargs, dict):
        raise ConfigError(f"env_kwargs must be a mapping, got {env_kwargs!r}")
    if env_kwargs.get("task", task) != task:
        raise ConfigError(f"env_kwargs sets task {env_kwargs['task']!r}, but the run trains task {task!r}")
    env_kwargs = {key: value for key, value in env_kwargs.items() if key != "task"}
    try:
        gym.make(rd.TASK_IDS[task], **env_kwargs).close()
    except (TypeError, ValueError) as error:
        raise ConfigError(f"env_kwargs: {error}") from None
    return env_kwargs


def positive_int(name: str, value) -> int:
    """``value`` as an int, if it is a whole number >= 1 (YAML writes 3e5 as a float)."""
    number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not (number and math.isfinite(value) and value == int(value) and value >= 1):
        raise ConfigError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


class PeriodicEvaluation(BaseCallback):
    """Evaluates the policy every ``every`` environment steps, as SB3's ``EvalCallback`` does, but on the native
    vector env with all episodes at once (:func:`agents.evaluate.evaluate`: one policy call per step for all of
    them, instead of one per episode and step): the same seeded episodes each time, deterministic actions, with the
    training's observation normalization. Keeps the best model (``best_model.zip``, with the normalization's
    statistics of that moment in ``best_vecnormalize.pkl``: :func:`agents.evaluate.normalization_file`), the evaluations
    (``eval/evaluations.npz``: ``timesteps``, ``results`` (returns), ``successes``, as EvalCallback writes them),
    logs ``eval/mean_reward`` and ``eval/success_rate``, and hands ``(num_timesteps, mean return, success rate)`` to
    the listeners.
    """

    def __init__(
        self,
        out: Path,
        every: int,
        episodes: int,
        seed: int,
        env_kwargs: dict,
        listeners: list[Callable[[int, float, float], None]],
    ):
        super().__init__()
        self.out, self.every, self.episodes, self.seed = out, every, episodes, seed
        self.env_kwargs, self.listeners = env_kwargs, listeners
        self.next = every
        self.best = -math.inf
        self.history: dict[str, list] = {"timesteps": [], "results": [], "successes": []}

    def _on_step(self) -> bool:
        if self.num_timesteps < self.next:
            return True
        self.next += self.every
        normalize = self.training_env if isinstance(self.training_env, VecNormalize) else None
        result = evaluate(
            NormalizedPolicy(self.model, normalize), "periodic", self.episodes, seed=self.seed, **self.env_kwargs
        )
        mean_return, success_rate = float(result.returns.mean()), float(result.successes.mean())
        for key, value in (
            ("timesteps", self.num_timesteps),
            ("results", result.returns),
            ("successes", result.successes),
        ):
            self.history[key].append(value)
        (self.out / "eval").mkdir(exist_ok=True)
        np.savez(self.out / "eval" / "evaluations.npz", **{key: np.array(value) for key, value in self.history.items()})
        self.logger.record("eval/mean_reward", mean_return)
        self.logger.record("eval/success_rate", success_rate)
        if mean_return > self.best:
            self.best = mean_return
            self.model.save(self.out / "best_model.zip")
            if normalize is not None:  # the statistics this model was evaluated with: they go on changing
                normalize.save(str(self.out / "best_vecnormalize.pkl"))
        for listener in self.listeners:
            listener(self.num_timesteps, mean_return, success_rate)
        return True


class _ProgressBar(BaseCallback):
    """A tqdm bar over the environment steps whose postfix shows the latest evaluation; where stderr is no
    terminal (a piped or logged run), one printed line per evaluation instead."""

    def __init__(self):
        super().__init__()
        self.bar = None

    def _on_training_start(self) -> None:
        total = self.locals["total_timesteps"] - self.model.num_timesteps
        self.bar = tqdm(total=total, unit="step", dynamic_ncols=True, disable=not sys.stderr.isatty())

    def _on_step(self) -> bool:
        # PPO's last rollout may run past the total: the bar stops at it.
        self.bar.update(min(self.training_env.num_envs, self.bar.total - self.bar.n))
        return True

    def _on_training_end(self) -> None:
        self.bar.close()

    def show(self, num_timesteps: int, mean_return: float, success_rate: float) -> None:
        text = f"eval return {mean_return:.1f}, success {success_rate:.0%}"
        if self.bar is not None and not self.bar.disable:
            self.bar.set_postfix_str(text)
        else:
            print(f"{num_timesteps} steps: {text}", flush=True)


def train(
    task: str,
    algo: str,
    hyperparams: dict,
    out: Path,
    *,
    timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int = 0,
    eval_episodes: int = 100,
    threads: int = 1,
    verbose: int = 0,
    progress_bar: bool = True,
    on_evaluation: Callable[[int, float, float], None] | None = None,
) -> list[Result]:
    """Trains ``algo`` on ``task`` with one zoo block of hyperparameters, then evaluates it against the baselines.

    The run directory ``out`` receives ``config.yml`` (the block as used, keyed by the task's id), ``command.txt``,
    ``algo.txt``, TensorBoard logs in ``tb/``, ``best_model.zip`` (and ``best_vecnormalize.pkl``, with ``normalize``)
    and ``eval/evaluations.npz``
    (:class:`PeriodicEvaluation`: every 10,000 steps, 10 episodes), ``model.zip``, ``vecnormalize.pkl`` (with
    ``normalize``) and ``results.md``.
    Ctrl-C (KeyboardInterrupt) during training stops it; the model trained so far is saved and evaluated.

    Args:
        task: a task name, a key of :data:`rolling_disk_env.TASK_IDS`.
        algo: ``"ppo"``, ``"sac"`` or ``"td3"``.
        hyperparams: one block of a zoo-format file, as in the YAML (:func:`load_hyperparams`); not modified.
        out: the run directory (created).
        timesteps: environment steps; default the block's ``n_timesteps``.
        n_envs: training environments, stepped together by the compiled engine
            (:func:`rolling_disk_env.sb3.make_vec_env`: the transitions of ``DummyVecEnv`` over single envs, in less
            time: ``benchmarks/bench_training.py``); default the block's ``n_envs`` or 1.
        seed: seeds the model and the training envs (the periodic evaluations' episodes: from ``seed + 1000``).
        eval_episodes: seeded episodes (seeds from ``agents.evaluate.EVAL_SEED``) of the final evaluation.
        threads: torch CPU threads (1 was fastest on 2 cores: ``benchmarks/bench_training.py``).
        verbose: SB3's verbosity, 0, 1 (training logs, evaluations) or 2 (debug).
        progress_bar: show a progress bar with the latest evaluation (or a line per evaluation off a terminal).
        on_evaluation: called as ``on_evaluation(num_timesteps, mean_return, success_rate)`` after every
            periodic evaluation.

    Returns:
        The final evaluation of the trained agent, the passive disk and the task's classical baseline (if it has
        one: :data:`agents.baselines.BASELINES`).

    Raises:
        ConfigError: unusable hyperparameters or arguments, before anything is trained or written.
    """
    if task not in rd.TASK_IDS:
        raise ConfigError(f"unknown task {task!r}; tasks: {sorted(rd.TASK_IDS)}")
    if algo not in ALGORITHMS:
        raise ConfigError(f"unknown algo {algo!r}; algorithms: {sorted(ALGORITHMS)}")
    if verbose not in (0, 1, 2):
        raise ConfigError(f"verbose must be 0, 1 or 2, got {verbose!r}")
    env_id = rd.TASK_IDS[task]
    timesteps = positive_int("timesteps", hyperparams.get("n_timesteps") if timesteps is None else timesteps)
    n_envs = positive_int("n_envs", hyperparams.get("n_envs", 1) if n_envs is None else n_envs)
    eval_episodes = positive_int("eval_episodes", eval_episodes)
    threads = positive_int("threads", threads)
    kwargs = algorithm_kwargs(algo, hyperparams)
    normalization = normalize_kwargs(hyperparams)
    env_kwargs = check_env_kwargs(task, hyperparams)

    torch.set_num_threads(threads)
    out.mkdir(parents=True, exist_ok=True)
    used = {**hyperparams, "n_timesteps": timesteps, "n_envs": n_envs}
    (out / "config.yml").write_text(yaml.safe_dump({env_id: used}, sort_keys=False))
    (out / "command.txt").write_text(shlex.join([sys.executable, *sys.argv]) + "\n")
    (out / "algo.txt").write_text(algo + "\n")

    env = native_vec_env(env_id, n_envs=n_envs, seed=seed, env_kwargs=env_kwargs)
    if normalization is not None:
        env = VecNormalize(env, **normalization)
    model = ALGORITHMS[algo](
        hyperparams.get("policy", "MlpPolicy"),
        env,
        seed=seed,
        device="cpu",
        verbose=verbose,
        tensorboard_log=str(out / "tb"),
        **kwargs,
    )
    bar = _ProgressBar() if progress_bar else None
    listeners = ([bar.show] if bar is not None else []) + ([on_evaluation] if on_evaluation is not None else [])
    evaluated = {"task": task, **env_kwargs}
    periodic = PeriodicEvaluation(out, EVAL_EVERY, EVAL_DURING_TRAINING, seed + 1000, evaluated, listeners)
    callbacks = [periodic, *([bar] if bar is not None else [])]
    start = time.perf_counter()
    interrupted = False
    try:
        model.learn(total_timesteps=timesteps, callback=callbacks, tb_log_name=algo)
    except KeyboardInterrupt:
        interrupted = True
        if bar is not None and bar.bar is not None:
            bar.bar.close()
        print("\ninterrupted: saving and evaluating the model trained so far", flush=True)
    minutes = (time.perf_counter() - start) / 60
    model.save(out / "model.zip")
    if normalization is not None:
        env.save(str(out / "vecnormalize.pkl"))

    trained = NormalizedPolicy(model, env if normalization is not None else None)
    title = f"{task}: {algo.upper()}, seed {seed}, {model.num_timesteps} steps in {minutes:.1f} min"
    return write_results(
        out,
        title + (" (interrupted)" if interrupted else ""),
        trained,
        f"{algo.upper()} (trained, {model.num_timesteps} steps)",
        eval_episodes,
        evaluated,
    )


def write_results(out: Path, title: str, agent, name: str, episodes: int, evaluated: dict) -> list[Result]:
    """The final evaluation of a run: ``agent`` (called ``name``), the passive disk and the task's classical baseline
    (if it has one: :data:`agents.baselines.BASELINES`) over the same ``episodes`` seeded episodes of the env
    ``evaluated`` (``task`` and the env's keyword arguments), written under ``title`` to ``out/results.md``."""
    results = [
        evaluate(agent, name, episodes, **evaluated),
        evaluate(PassiveAgent(), "passive disk (zero torque)", episodes, **evaluated),
    ]
    task = evaluated["task"]
    if task in BASELINES:
        baseline = BASELINES[task]
        results.append(evaluate(baseline(**evaluated), f"baseline: {baseline.__name__}", episodes, **evaluated))
    header = (
        f"# {title}\n\n"
        f"{episodes} evaluation episodes (seeds {EVAL_SEED} to {EVAL_SEED + episodes - 1}), deterministic actions.\n\n"
    )
    (out / "results.md").write_text(header + results_table(results) + "\n")
    return results
