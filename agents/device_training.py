"""PPO on the device the disks live on: rsl-rl-lib's ``OnPolicyRunner`` (Isaac Lab's PPO) on the torch vector env,
what ``train.py --device cuda`` (or ``cpu``) runs.

The observations, actions, rewards and flags stay torch tensors on the device from the env's kernels to the policy's
update: nothing crosses to the host during a rollout but the per-iteration log. Hyperparameters are blocks of
``agents/hyperparams/rsl_rl_ppo.yml``, keyed by the per-task env ids like the zoo files: ``num_envs``,
``num_steps_per_env``, ``max_iterations``, ``env_kwargs``, and rsl_rl's own ``algorithm``, ``actor`` and ``critic``
configurations. The run directory gets what ``train.py`` writes for SB3 (``config.yml``, ``command.txt``,
``algo.txt``, TensorBoard logs in ``tb/``, ``results.md``), with the model as ``model.pt`` (rsl_rl's checkpoint) and
``policy.pt2`` (``torch.export``'s program, its observation normalization included: what ``agents.evaluate --model``
loads).
"""

from __future__ import annotations

import contextlib
import copy
import logging
import math
import os
import shlex
import sys
import time
from pathlib import Path

import gymnasium as gym
import torch
import yaml

import rolling_disk_env as rd
from agents.evaluate import ExportedPolicy, Result
from agents.training import ConfigError, check_env_kwargs, positive_int, write_results

try:
    from rsl_rl.env import VecEnv
    from rsl_rl.runners import OnPolicyRunner
    from tensordict import TensorDict
except ImportError as error:
    raise ImportError(f'train.py --device needs rsl-rl-lib: pip install torch==2.13.0 -e ".[gpu]" ({error})') from error

log = logging.getLogger(__name__)
RUNNER_KEYS = frozenset({"num_envs", "num_steps_per_env", "max_iterations", "env_kwargs"})
"""The keys of a block that :func:`train_on_device` reads itself; the others go to rsl_rl's runner as they are."""


class RslRlVecEnv(VecEnv):
    """The torch vector env of a task as rsl_rl's ``VecEnv``: same-step autoreset (the step that ends an episode
    returns the next one's first observation), ``dones`` terminated or truncated, ``extras["time_outs"]`` the
    truncations (rsl_rl bootstraps their value), and in ``extras["log"]`` the success rate of the episodes that ended.

    Args:
        task: a key of :data:`rolling_disk_env.TASK_IDS`.
        num_envs: disks stepped together.
        device: ``"cuda"`` or ``"cpu"``, the torch env's device.
        seed: the first disk's seed (disk i: seed + i).
        env_kwargs: the env's keyword arguments.
        steps_per_iteration: rsl_rl's ``num_steps_per_env``: the success rate is logged once an iteration.
    """

    def __init__(
        self, task: str, num_envs: int, device: str, seed: int, env_kwargs: dict, steps_per_iteration: int = 1
    ):
        self.env = gym.make_vec(
            rd.TASK_IDS[task],
            num_envs=num_envs,
            vectorization_mode="vector_entry_point",
            device=device,
            autoreset_mode="SameStep",
            **env_kwargs,
        )
        self.num_envs = num_envs
        self.num_actions = self.env.single_action_space.shape[0]
        self.max_episode_length = rd.TASK_MAX_STEPS[task]
        self.num_obs = self.env.single_observation_space.shape[0]
        self.device = self.env.unwrapped.device
        self.cfg = {"task": task, "num_envs": num_envs, "device": str(device), **env_kwargs}
        self._observations, _ = self.env.reset(seed=seed)
        self._steps_per_iteration, self._steps = steps_per_iteration, 0
        self._successes = torch.zeros((), dtype=torch.float32, device=self.device)
        self._ended = torch.zeros((), dtype=torch.float32, device=self.device)

    @property
    def episode_length_buf(self) -> torch.Tensor:
        """(N,) int64: each disk's steps in its episode, the env's own counters (a view): rsl_rl's
        ``init_at_random_ep_len`` sets them, and the disks then truncate at different steps."""
        return self.env.unwrapped.steps

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:
        self.env.unwrapped.steps = value

    def get_observations(self) -> TensorDict:
        return TensorDict({"policy": self._observations}, batch_size=[self.num_envs])

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """A step; the success rate of the episodes that ended in an iteration (``steps_per_iteration`` steps) goes to
        ``extras["log"]`` at its last step, summed and counted on the device (no read of the flags a step)."""
        self._observations, rewards, terminated, truncated, info = self.env.step(actions)
        dones = terminated | truncated
        extras = {"time_outs": truncated & ~terminated, "log": {}}
        if "final_info" in info:  # on the GPU at every step, its mask False where nothing ended
            ended = info["_final_info"]
            self._successes += (info["final_info"]["is_success"] & ended).sum()
            self._ended += ended.sum()
        self._steps += 1
        if self._steps % self._steps_per_iteration == 0:
            extras["log"]["/success_rate"] = self._successes / self._ended.clamp(min=1.0)
            self._successes, self._ended = torch.zeros_like(self._successes), torch.zeros_like(self._ended)
        return self.get_observations(), rewards, dones.long(), extras

    def close(self) -> None:
        self.env.close()


def export_policy(runner, observation_size: int, path: Path) -> None:
    """Saves the trained actor with its observation normalization (rsl_rl's ``as_jit`` module) as ``torch.export``'s
    program of a batch of observations (any size) to a batch of actions, on the CPU: what torch recommends now over
    TorchScript (``torch.jit.script``, which rsl_rl's own export calls, is deprecated)."""
    model = runner.alg.get_policy().as_jit().to("cpu").eval()
    batch = torch.export.Dim("batch")
    program = torch.export.export(model, (torch.zeros(2, observation_size),), dynamic_shapes=({0: batch},))
    torch.export.save(program, path)


def train_on_device(
    task: str,
    hyperparams: dict,
    out: Path,
    *,
    device: str = "cuda",
    timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int = 0,
    eval_episodes: int = 100,
    threads: int = 1,
    verbose: int = 0,
) -> list[Result]:
    """Trains rsl_rl's PPO on ``task`` with the disks and the policy on ``device``, then evaluates it against the
    baselines as :func:`agents.training.train` does (the same seeded episodes, the same table).

    Args:
        task: a key of :data:`rolling_disk_env.TASK_IDS`.
        hyperparams: one block of ``agents/hyperparams/rsl_rl_ppo.yml`` (not modified).
        out: the run directory (created).
        device: ``"cuda"`` or ``"cpu"``.
        timesteps: environment steps (rounded up to whole iterations); default the block's ``max_iterations``.
        n_envs: disks stepped together; default the block's ``num_envs``.
        seed: seeds torch and the training disks.
        eval_episodes: seeded episodes of the final evaluation.
        threads: torch CPU threads.
        verbose: 1 prints rsl_rl's log of every iteration.

    Raises:
        ConfigError: unusable hyperparameters or arguments, before anything is trained or written.
    """
    if task not in rd.TASK_IDS:
        raise ConfigError(f"unknown task {task!r}; tasks: {sorted(rd.TASK_IDS)}")
    env_id = rd.TASK_IDS[task]
    num_envs = positive_int("num_envs", hyperparams.get("num_envs") if n_envs is None else n_envs)
    steps_per_env = positive_int("num_steps_per_env", hyperparams.get("num_steps_per_env"))
    iterations = positive_int("max_iterations", hyperparams.get("max_iterations"))
    if timesteps is not None:
        iterations = math.ceil(positive_int("timesteps", timesteps) / (num_envs * steps_per_env))
    env_kwargs = check_env_kwargs(task, hyperparams)
    runner_cfg = {key: copy.deepcopy(value) for key, value in hyperparams.items() if key not in RUNNER_KEYS}
    missing = sorted({"algorithm", "actor", "critic"} - runner_cfg.keys())
    if missing:
        raise ConfigError(f"the block has no {missing}: rsl_rl's runner needs them")
    # No NaN check of rsl_rl's (two reads of the device a step): the kernels end an episode whose state leaves the
    # model's domain, and the observations are clipped to their bounds.
    runner_cfg.update(
        num_steps_per_env=steps_per_env, save_interval=iterations, logger="tensorboard", check_for_nan=False
    )
    runner_cfg.setdefault("obs_groups", {"actor": ["policy"], "critic": ["policy"]})

    torch.manual_seed(seed)
    torch.set_num_threads(positive_int("threads", threads))
    out.mkdir(parents=True, exist_ok=True)
    used = {**hyperparams, "num_envs": num_envs, "max_iterations": iterations}
    (out / "config.yml").write_text(yaml.safe_dump({env_id: used}, sort_keys=False))
    (out / "command.txt").write_text(shlex.join([sys.executable, *sys.argv]) + "\n")
    (out / "algo.txt").write_text("rsl_rl_ppo\n")

    start = time.perf_counter()
    env = RslRlVecEnv(task, num_envs, device, seed, env_kwargs, steps_per_env)
    log.info("the env of %d disks on %s made and reset in %.1f s", num_envs, device, time.perf_counter() - start)
    with contextlib.ExitStack() as stack:
        if not verbose:  # rsl_rl prints its models and a table an iteration
            stack.enter_context(contextlib.redirect_stdout(stack.enter_context(open(os.devnull, "w"))))
        runner = OnPolicyRunner(env, runner_cfg, log_dir=str(out / "tb"), device=str(env.device))
        start = time.perf_counter()
        runner.learn(iterations)
        minutes = (time.perf_counter() - start) / 60
    log.info("%d iterations of rsl_rl trained in %.1f s (the first step compiles)", iterations, 60 * minutes)
    env.close()
    runner.save(str(out / "model.pt"))
    export_policy(runner, env.num_obs, out / "policy.pt2")

    evaluated = {"task": task, **env_kwargs}
    trained = num_envs * steps_per_env * iterations
    title = f"{task}: PPO (rsl_rl) on {device}, seed {seed}, {trained} steps in {minutes:.1f} min ({num_envs} envs)"
    policy = ExportedPolicy(out / "policy.pt2")
    start = time.perf_counter()
    results = write_results(out, title, policy, f"PPO (rsl_rl, {device}, {trained} steps)", eval_episodes, evaluated)
    log.info("the final evaluation (%d episodes, on the CPU) took %.1f s", eval_episodes, time.perf_counter() - start)
    return results
