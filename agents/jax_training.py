"""PPO compiled with the env into one XLA program: rejax's PPO on the gymnax env of a task (``train.py --jax``).

The rollouts, the disks' steps and the updates of the policy run in one ``jax.jit``-compiled function of a key
(rejax, PureJaxRL's style): nothing returns to Python until the training ends. Hyperparameters are blocks of
``agents/hyperparams/rejax_ppo.yml``, keyed by the per-task env ids like the zoo files; ``env_kwargs`` go to the env,
``log_std_init`` sets the policy's initial log standard deviation, the other keys go to ``rejax.PPO.create`` as they
are. The trained policy is then evaluated on the Gymnasium env (the numba engine) over the same seeded episodes as
every other trainer, so the results tables compare: the run directory gets ``config.yml``, ``command.txt``,
``algo.txt``, ``results.md``, ``timings.md`` (compile and training time) and ``policy.msgpack`` (the actor's
parameters and the observation statistics, flax's serialization).

rejax 0.1.3 reads gymnax 0.0's step, ``(obs, state, reward, done, info)``; gymnax 1.0's returns ``terminated`` and
``truncated`` apart. :class:`DoneStep` gives rejax the older form, ``done = terminated | truncated``, as
gymnax's own wrappers for such trainers do.
"""

from __future__ import annotations

import logging
import os
import shlex
import sys
import time
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import yaml
from flax import serialization

import rolling_disk_env as rd
from agents.evaluate import Result
from agents.training import ConfigError, check_env_kwargs, positive_int, write_results
from rolling_disk_env.jax import RollingDiskJax

try:
    # rejax imports distrax, which imports TensorFlow Probability's JAX backend; that one reads
    # jax.core.pytype_aval_mappings at import and JAX warns of its deprecation: nothing a user of train.py --jax can
    # act on, so filtered by its message here, around the import that raises it.
    with warnings.catch_warnings():
        warnings.filterwarnings(
            "ignore", message=r"jax\.core\.pytype_aval_mappings is deprecated", category=DeprecationWarning
        )
        from rejax import PPO
except ImportError as error:
    raise ImportError(f'train.py --jax needs rejax: pip install torch==2.13.0 -e ".[jax]" ({error})') from error

log = logging.getLogger(__name__)

OWN_KEYS = frozenset({"env_kwargs", "log_std_init"})
"""The keys of a block that :func:`train_in_jax` reads itself; the others go to ``rejax.PPO.create``."""


def use_compilation_cache() -> Path:
    """Turns on XLA's persistent compilation cache for this process, so that a second run of the same configuration
    loads the compiled training instead of compiling it again, and returns its folder: JAX's own setting where one
    was made (``JAX_COMPILATION_CACHE_DIR``), else ``$XDG_CACHE_HOME/rolling-disk-env/xla`` (``~/.cache`` without
    it). Where the folder cannot be written, JAX warns and compiles."""
    configured = jax.config.jax_compilation_cache_dir
    if configured:
        return Path(configured)
    path = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "rolling-disk-env" / "xla"
    jax.config.update("jax_compilation_cache_dir", str(path))
    return path


class DoneStep:
    """A gymnax 1.0 env whose ``step`` returns gymnax 0.0's five values, ``done`` being ``terminated |
    truncated`` (what rejax 0.1.3 unpacks); everything else is the env's."""

    def __init__(self, env):
        self.env = env

    def __getattr__(self, name):
        if name == "env":  # not set yet (copy.deepcopy, which rejax applies to its config, builds one bare)
            raise AttributeError(name)
        return getattr(self.env, name)

    def step(self, key, state, action, params):
        observation, state, reward, terminated, truncated, info = self.env.step(key, state, action, params)
        return observation, state, reward, terminated | truncated, info

    def reset(self, key, params):
        return self.env.reset(key, params)


def _algorithm(task: str, env_kwargs: dict, config: dict):
    """rejax's PPO of a block's ``config`` (its ``eval_freq`` cut to the steps asked for: rejax trains in whole
    evaluation periods) on the task's gymnax env; ``ConfigError`` for what the env or rejax refuses."""
    config["eval_freq"] = min(positive_int("eval_freq", config.get("eval_freq", 4096)), config["total_timesteps"])
    try:
        env = RollingDiskJax(task, **env_kwargs)
    except ValueError as error:
        raise ConfigError(str(error)) from error
    try:
        return PPO.create(env=DoneStep(env), env_params=env.default_params, **config)
    except TypeError as error:
        raise ConfigError(f"rejax's PPO: {error}") from error


def _start(algo, hyperparams: dict, key: jax.Array):
    """rejax's initial training state from ``key``, its policy's log standard deviation set to the block's
    ``log_std_init`` where it has one."""
    start = algo.init_state(key)
    if "log_std_init" in hyperparams:
        actor = start.actor_ts.params
        log_std = jnp.full_like(actor["params"]["action_log_std"], float(hyperparams["log_std_init"]))
        actor = {**actor, "params": {**actor["params"], "action_log_std": log_std}}
        start = start.replace(actor_ts=start.actor_ts.replace(params=actor))
    return start


def train_seeds_in_jax(task: str, hyperparams: dict, seeds: list[int]) -> dict:
    """Trains rejax's PPO on the gymnax env of ``task`` once per seed, the seeds ``vmap``ped in one XLA program
    (PureJaxRL's way: the runs of every seed in one compiled function, a batch of its own each), with the block
    ``hyperparams`` as :func:`train_in_jax` reads it.

    Returns:
        ``{"policies": [JaxPolicy per seed], "returns": (seeds, evaluations) mean return of rejax's evaluation
        episodes every ``eval_freq`` steps, "eval_freq": steps, "compile_s": s, "train_s": s}``: the training's wall
        time is that of all seeds together (one program), its compile apart.
    """
    env_kwargs = check_env_kwargs(task, hyperparams)
    config = {key: value for key, value in hyperparams.items() if key not in OWN_KEYS}
    config["total_timesteps"] = positive_int("total_timesteps", config.get("total_timesteps"))
    with jax.enable_x64(False):
        algo = _algorithm(task, env_kwargs, config)
        starts = jax.vmap(lambda key: _start(algo, hyperparams, key))(
            jnp.stack([jax.random.PRNGKey(seed) for seed in seeds])
        )
        use_compilation_cache()
        began = time.perf_counter()
        train = jax.jit(jax.vmap(lambda state: algo.train(train_state=state))).lower(starts).compile()
        compiled = time.perf_counter()
        states, (_, returns) = jax.block_until_ready(train(starts))
        trained = time.perf_counter()
        policies = [JaxPolicy(algo, jax.tree.map(lambda leaf, i=i: leaf[i], states)) for i in range(len(seeds))]
    return {
        "policies": policies,
        "returns": np.asarray(returns).mean(axis=-1),
        "eval_freq": config["eval_freq"],
        "compile_s": compiled - began,
        "train_s": trained - compiled,
    }


class JaxPolicy:
    """The trained actor as ``agents.evaluate`` calls it: the mean action of rejax's Gaussian policy on the
    observation normalized with the training's statistics, for a batch of observations (float32)."""

    def __init__(self, algo, train_state):
        actor, params = algo.actor, train_state.actor_ts.params
        statistics = train_state.obs_rms_state if algo.normalize_observations else None

        def act(observations):
            if statistics is not None:
                observations = algo.normalize_obs(statistics, observations)
            mean = actor.apply(params, observations, method=lambda module, x: module._action_dist(x).mode())
            return jnp.clip(mean, -1.0, 1.0)

        self._act = jax.jit(act)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.asarray(self._act(jnp.asarray(observation, jnp.float32)), dtype=np.float32), None


def train_in_jax(
    task: str,
    hyperparams: dict,
    out: Path,
    *,
    timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int = 0,
    eval_episodes: int = 100,
    threads: int = 1,
    verbose: int = 0,
) -> list[Result]:
    """Trains rejax's PPO on the gymnax env of ``task``, then evaluates it against the baselines on the Gymnasium env
    as :func:`agents.training.train` does (the same seeded episodes, the same table).

    Args:
        task: a key of :data:`rolling_disk_env.TASK_IDS`.
        hyperparams: one block of ``agents/hyperparams/rejax_ppo.yml`` (not modified).
        out: the run directory (created).
        timesteps: environment steps; default the block's ``total_timesteps``.
        n_envs: disks stepped together; default the block's ``num_envs``.
        seed: the training's key, ``jax.random.PRNGKey(seed)``.
        eval_episodes: seeded episodes of the final evaluation.
        threads: unused (XLA takes the CPU's cores); accepted as the other trainers take it.
        verbose: 1 prints the periodic evaluations' mean return.

    Raises:
        ConfigError: unusable hyperparameters or arguments, before anything is trained or written.
    """
    if task not in rd.TASK_IDS:
        raise ConfigError(f"unknown task {task!r}; tasks: {sorted(rd.TASK_IDS)}")
    env_id = rd.TASK_IDS[task]
    env_kwargs = check_env_kwargs(task, hyperparams)
    config = {key: value for key, value in hyperparams.items() if key not in OWN_KEYS}
    config["num_envs"] = positive_int("num_envs", config.get("num_envs") if n_envs is None else n_envs)
    config["total_timesteps"] = positive_int(
        "total_timesteps", config.get("total_timesteps") if timesteps is None else timesteps
    )
    with jax.enable_x64(False):  # rejax's networks and statistics are float32: the env runs in float32 too
        algo = _algorithm(task, env_kwargs, config)
        out.mkdir(parents=True, exist_ok=True)
        (out / "config.yml").write_text(yaml.safe_dump({env_id: {**hyperparams, **config}}, sort_keys=False))
        (out / "command.txt").write_text(shlex.join([sys.executable, *sys.argv]) + "\n")
        (out / "algo.txt").write_text("rejax_ppo\n")

        start = _start(algo, hyperparams, jax.random.PRNGKey(seed))
        cache = use_compilation_cache()
        began = time.perf_counter()
        train = jax.jit(lambda state: algo.train(train_state=state)).lower(start).compile()
        compiled = time.perf_counter()
        log.info("XLA compiled the training (or loaded it) in %.1f s; its cache: %s", compiled - began, cache)
        train_state, (_, returns) = jax.block_until_ready(train(start))
        trained = time.perf_counter()
        if verbose:
            for evaluation, mean in enumerate(np.asarray(returns).mean(axis=1)):
                print(f"evaluation {evaluation}: mean return {mean:.1f}")
        statistics = train_state.obs_rms_state if algo.normalize_observations else None
        saved = {"actor": train_state.actor_ts.params, "observation_statistics": statistics}
        (out / "policy.msgpack").write_bytes(serialization.to_bytes(saved))
        compile_s, train_s = compiled - began, trained - compiled
        (out / "timings.md").write_text(
            "| what | seconds |\n| --- | --- |\n"
            f"| XLA compile of the training (env, rollouts, updates; or its load from {cache}) | {compile_s:.1f} |\n"
            f"| training, {config['total_timesteps']} steps | {train_s:.1f} |\n"
        )
        title = (
            f"{task}: PPO (rejax, JAX) seed {seed}, {config['total_timesteps']} steps in {train_s:.1f} s "
            f"(+ {compile_s:.1f} s XLA compile, {config['num_envs']} envs)"
        )
        policy = JaxPolicy(algo, train_state)
        name = f"PPO (rejax, {config['total_timesteps']} steps)"
        return write_results(out, title, policy, name, eval_episodes, {"task": task, **env_kwargs})
