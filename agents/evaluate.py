"""Evaluate agents on rolling-disk-env: a table of return and success, a video of one episode, and plots.

Seeded episodes (seeds from 10000) run at once on the native vector env; the table gives mean +- std return and the
success rate. --out DIR writes episode.gif (the env's renderer) and episode.png (lean, rates, torques and the track
seen from above against the target) of the first episode; --render human shows it live.

examples:
  python -m agents.evaluate --task circle --agent baseline --out eval/   # the task's classical controller
  python -m agents.evaluate --agent passive --episodes 20                 # zero torque, task upright
  python -m agents.evaluate --model runs/upright_ppo_0/model.zip --render human
  python -m agents.evaluate --model runs/upright_rsl_rl_cuda_0/policy.pt2  # a policy of train.py --device
A model's task and env keyword arguments come from the config.yml that train.py saved beside it.
"""

from __future__ import annotations

import argparse
import pickle
import sys
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import yaml
from stable_baselines3 import PPO, SAC, TD3
from tqdm import tqdm

import rolling_disk_env as rd
from agents import show_compiling
from agents.baselines import BASELINES

ALGORITHMS = {"ppo": PPO, "sac": SAC, "td3": TD3}
"""The SB3 algorithms train.py offers, by its --algo name."""
EVAL_SEED = 10_000
"""Evaluation episodes use seeds from here on: training uses others."""
AGENTS = {
    "baseline": "the task's classical controller",
    "lqr": "an alias of baseline",
    "passive": "zero torque",
}
"""The agents evaluate's CLI names (a trained model is given by its path, ``--model``)."""


@dataclass(frozen=True)
class Result:
    """Return and success over evaluation episodes."""

    name: str
    returns: np.ndarray
    successes: np.ndarray

    def row(self) -> list[str]:
        return [
            self.name,
            f"{self.returns.mean():.1f} +- {self.returns.std():.1f}",
            f"{100 * self.successes.mean():.0f}%",
        ]


def results_table(results: list[Result]) -> str:
    """A markdown table of the results: agent, mean +- std return, success rate."""
    rows = ["| " + " | ".join(result.row()) + " |" for result in results]
    return "\n".join(["| agent | return (mean +- std) | success |", "|---|---|---|", *rows])


class PassiveAgent:
    """Zero torque: the disk rolls on its own."""

    def __init__(self, action_size: int = 2):
        self.action_size = action_size

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        observation = np.asarray(observation)
        return np.zeros((*observation.shape[:-1], self.action_size), dtype=np.float32), None


class NormalizedPolicy:
    """A trained SB3 model with the VecNormalize observation statistics it was trained with."""

    def __init__(self, model, normalize=None):
        self.model, self.normalize = model, normalize

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if self.normalize is not None:
            observation = self.normalize.normalize_obs(np.asarray(observation, dtype=np.float32))
        return self.model.predict(observation, deterministic=deterministic)


class ExportedPolicy:
    """A policy exported with ``torch.export`` (``policy.pt2`` of ``train.py --device``: rsl_rl's actor with its
    observation normalization, a batch of observations to a batch of actions), run on the CPU."""

    def __init__(self, path: Path):
        import torch

        self.torch, self.policy = torch, torch.export.load(str(path)).module()

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        with self.torch.inference_mode():
            actions = self.policy(self.torch.as_tensor(np.asarray(observation, dtype=np.float32)))
        return actions.numpy(), None


def normalization_file(model: Path) -> Path:
    """Where the observation statistics of a saved model are: ``best_vecnormalize.pkl`` for ``best_model.zip`` (the
    statistics of the training at the evaluation that found it the best: they go on changing after it), where there
    is one, else ``vecnormalize.pkl`` (the end of the training's, saved with ``model.zip``)."""
    best = model.parent / "best_vecnormalize.pkl"
    return best if model.stem == "best_model" and best.exists() else model.parent / "vecnormalize.pkl"


def load_agent(path: Path):
    """A saved model: an SB3 ``.zip`` with its observation statistics (:func:`normalization_file`), if there are any,
    or an exported policy ``.pt2`` (:class:`ExportedPolicy`)."""
    from stable_baselines3.common.vec_env import VecNormalize

    if path.suffix == ".pt2":
        return ExportedPolicy(path)

    run = path.parent
    algo = (run / "algo.txt").read_text().strip() if (run / "algo.txt").exists() else "ppo"
    model = ALGORITHMS[algo].load(path, device="cpu")
    normalize = None
    stats = normalization_file(path)
    if stats.exists():
        # VecNormalize.save pickles the statistics without the training envs; normalize_obs needs only those.
        with open(stats, "rb") as handle:
            normalize = pickle.load(handle)
        if not isinstance(normalize, VecNormalize):
            raise ValueError(f"{stats} does not hold VecNormalize statistics")
        normalize.training = False
    return NormalizedPolicy(model, normalize)


def evaluate(
    agent, name: str, episodes: int = 100, seed: int = EVAL_SEED, on_step=None, progress: bool = False, **env_kwargs
) -> Result:
    """Runs ``episodes`` seeded episodes at once on the native vector env, one episode per sub-environment;
    ``on_step(infos, running)``, if given, sees every step's batched info with the mask of the episodes it belongs to
    (those that had not ended before it). With ``progress``, a line says what runs and, on a terminal, a bar counts
    the steps to the longest episode's end."""
    task = env_kwargs.get("task", "upright")
    steps = rd.TASK_MAX_STEPS[task]
    env = rd.RollingDiskVectorEnv(num_envs=episodes, max_episode_steps=steps, **env_kwargs)
    if progress:
        print(f"evaluating {name} on {episodes} seeded episodes of task {task} (up to {steps} steps)", flush=True)
    bar = tqdm(total=steps, unit="step", disable=None if progress else True, leave=False)
    observations, _ = env.reset(seed=seed)
    returns = np.zeros(episodes)
    successes = np.zeros(episodes, dtype=bool)
    finished = np.zeros(episodes, dtype=bool)
    while not finished.all():
        actions, _ = agent.predict(observations, deterministic=True)
        observations, rewards, terminated, truncated, infos = env.step(actions)
        if on_step is not None:
            on_step(infos, ~finished)
        returns += np.where(finished, 0.0, rewards)
        ending = (terminated | truncated) & ~finished
        successes |= ending & infos["is_success"]
        finished |= ending
        bar.update()
    bar.close()
    return Result(name, returns, successes)


def record_episode(agent, seed: int = EVAL_SEED, render_mode: str = "rgb_array", **env_kwargs) -> dict:
    """One episode on the single env: times, states, torques, the goal, the task and, with ``render_mode``
    ``"rgb_array"``, the frames (``"human"`` shows the episode in a window instead, at the env's pace)."""
    steps = rd.TASK_MAX_STEPS[env_kwargs.get("task", "upright")]
    env = gym.make(rd.ENV_ID, render_mode=render_mode, max_episode_steps=steps, **env_kwargs)
    observation, info = env.reset(seed=seed)
    unwrapped = env.unwrapped
    limits = np.array(unwrapped.config.max_torque)
    recording = render_mode == "rgb_array"
    states, torques, frames = [info["state"]], [np.zeros(2)], [env.render()] if recording else []
    episode_return = 0.0
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = agent.predict(observation, deterministic=True)
        observation, reward, terminated, truncated, info = env.step(action)
        episode_return += reward
        states.append(info["state"])
        torques.append(np.clip(action, -1, 1) * limits)
        if recording:
            frames.append(env.render())
    env.close()
    times = np.arange(len(states)) * unwrapped.dt
    return {
        "times": times,
        "states": np.array(states),
        "torques": np.array(torques),
        "frames": frames,
        "goal": unwrapped.goal,
        "task": unwrapped.task,
        "return": episode_return,
        "success": bool(info["is_success"]),
    }


def write_gif(frames: list[np.ndarray], path: Path, fps: int = 25, every: int = 2) -> Path:
    """An animated GIF of every ``every``-th frame (the env runs at 50 frames per second)."""
    from PIL import Image

    images = [Image.fromarray(frame) for frame in frames[::every]]
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    return path


def plot_episode(episode: dict, title: str, path: Path) -> Path:
    """Writes :func:`episode_figure` to ``path`` (PNG)."""
    import matplotlib.pyplot as plt

    fig = episode_figure(episode, title)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def episode_figure(episode: dict, title: str):
    """A matplotlib figure of an episode: lean theta(t), rates, torques, and the track from above against the
    target."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times, states, torques, goal = episode["times"], episode["states"], episode["torques"], episode["goal"]
    fig, axes = plt.subplots(2, 2, figsize=(10, 7))
    ax = axes[0, 0]
    ax.plot(times, np.degrees(states[:, 3]), label="theta")
    if "theta" in goal:
        ax.axhline(np.degrees(goal["theta"]), color="tab:green", ls="--", label="steady-circle lean")
    ax.axhline(np.degrees(episode["task"].fall_lean), color="tab:red", lw=0.8, ls=":", label="fall")
    ax.axhline(-np.degrees(episode["task"].fall_lean), color="tab:red", lw=0.8, ls=":")
    ax.set(xlabel="t (s)", ylabel="lean (deg)", title="lean")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    ax.plot(times, states[:, 5], label="dphi (spin)")
    ax.plot(times, states[:, 7], label="dpsi (heading)")
    if "dphi" in goal:
        ax.axhline(goal["dphi"], color="tab:green", ls="--", label="target dphi")
    ax.set(xlabel="t (s)", ylabel="rad/s", title="rates")
    ax.legend(fontsize=8)
    ax = axes[1, 0]
    ax.plot(times, torques[:, 0], label="spin torque")
    ax.plot(times, torques[:, 1], label="steer torque")
    ax.set(xlabel="t (s)", ylabel="N m", title="torques")
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    ax.plot(states[:, 0], states[:, 1], label="centre track")
    ax.plot(states[0, 0], states[0, 1], "o", color="tab:blue", label="start")
    task = episode["task"]
    for j, mark in enumerate(task.marks(goal)):
        ax.plot(mark[:, 0], mark[:, 1], "--", color="tab:green", label=task.mark_label if j == 0 else None)
    # Equal scales on x and y, but the panel keeps its size: the data limits grow instead (a straight track would
    # otherwise squeeze the panel into a strip).
    ax.set(xlabel="x (m)", ylabel="y (m)", title="track from above")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def make_agent(name: str, task: str, **env_kwargs):
    """An agent of :data:`AGENTS` by name for ``task`` (``"baseline"`` and ``"lqr"``: :data:`BASELINES`)."""
    if name == "passive":
        return PassiveAgent()
    if name in ("baseline", "lqr"):
        return BASELINES[task](task=task, **env_kwargs)
    raise ValueError(f"unknown agent {name!r}; agents: {sorted(AGENTS)}")


def run_settings(model: Path) -> tuple[str, dict] | None:
    """The task and env keyword arguments of the run a saved model comes from, read from ``config.yml`` in its
    folder (train.py's, keyed by the task's env id); None if there is none."""
    path = model.parent / "config.yml"
    if not path.exists():
        return None
    blocks = yaml.safe_load(path.read_text())
    if not (isinstance(blocks, dict) and len(blocks) == 1):
        raise ValueError(f"{path} must hold one hyperparameter block, keyed by env id")
    ((env_id, block),) = blocks.items()
    env_kwargs = dict((block or {}).get("env_kwargs") or {})
    tasks = {env_id: task for task, env_id in rd.TASK_IDS.items()}
    task = env_kwargs.pop("task", tasks.get(env_id, "upright"))
    return task, env_kwargs


def _agent_name(value: str) -> str:
    if value not in AGENTS:
        raise argparse.ArgumentTypeError(
            f"unknown agent {value!r}: choose {', '.join(sorted(AGENTS))}, or give a trained model with --model PATH"
        )
    return value


def _integer(minimum: int):
    """argparse type: an integer >= ``minimum``."""

    def parse(value: str) -> int:
        try:
            number = int(value)
        except ValueError:
            number = None
        if number is None or number < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {value!r}")
        return number

    return parse


def _model_file(value: str) -> Path:
    path = Path(value)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such model file: {value}")
    return path


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the docstring's layout and shows each option's default, when it has one."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.default not in (None, False, argparse.SUPPRESS) and "%(default)" not in action.help:
            return f"{action.help} (default: %(default)s)"
        return action.help


def main(argv: list[str] | None = None) -> Result:
    show_compiling()
    description, _, epilog = __doc__.partition("examples:")
    parser = argparse.ArgumentParser(
        prog="python -m agents.evaluate",
        description=description,
        epilog="examples:" + epilog,
        formatter_class=_HelpFormatter,
    )
    parser.add_argument("--task", choices=sorted(rd.TASK_IDS), help="the task (default: the model's, else upright)")
    agents = ", ".join(f"{name} ({meaning})" for name, meaning in AGENTS.items())
    parser.add_argument("--agent", type=_agent_name, metavar="NAME", help=f"{agents} (default: baseline)")
    parser.add_argument("--model", type=_model_file, metavar="PATH", help="a model .zip saved by train.py")
    parser.add_argument("--episodes", type=_integer(1), default=100, metavar="N", help="seeded evaluation episodes")
    parser.add_argument("--seed", type=_integer(0), default=EVAL_SEED, metavar="S", help="the first episode's seed")
    parser.add_argument("--out", type=Path, metavar="DIR", help="folder for episode.gif and episode.png")
    parser.add_argument("--render", choices=["human"], help="show the first episode live in a window")
    args = parser.parse_args(argv)
    if args.model and args.agent:
        parser.error("give either --agent or --model")
    env_kwargs = {}
    task = args.task or "upright"
    if args.model:
        settings = run_settings(args.model)
        if settings is not None:
            task, env_kwargs = settings
            if args.task not in (None, task):
                parser.error(
                    f"--task {args.task} contradicts the model's run: {args.model.parent / 'config.yml'} "
                    f"trains task {task!r}"
                )
        agent, name = load_agent(args.model), str(args.model)
    else:
        name = args.agent or "baseline"
        if name in ("baseline", "lqr") and task not in BASELINES:
            parser.error(f"task {task!r} has no classical baseline; tasks with one: {', '.join(BASELINES)}")
        agent = make_agent(name, task, **env_kwargs)
        name = f"baseline: {type(agent).__name__}" if name in ("baseline", "lqr") else name
    result = evaluate(agent, name, args.episodes, args.seed, progress=True, task=task, **env_kwargs)
    print(results_table([result]))
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        episode = record_episode(agent, args.seed, task=task, **env_kwargs)
        print(f"wrote {write_gif(episode['frames'], args.out / 'episode.gif')}")
        print(f"wrote {plot_episode(episode, f'{name} on {task}, seed {args.seed}', args.out / 'episode.png')}")
    if args.render == "human":
        import pygame

        try:
            episode = record_episode(agent, args.seed, render_mode="human", task=task, **env_kwargs)
        except pygame.error as error:
            sys.exit(f"error: cannot open a window ({error}); without a display, set SDL_VIDEODRIVER=dummy")
        print(f"watched seed {args.seed}: return {episode['return']:.1f}, success {episode['success']}")
    return result


if __name__ == "__main__":
    main()
