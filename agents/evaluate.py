"""Evaluate agents on RollingDisk-v0: a table of return and success, a video of one episode, and plots.

``python -m agents.evaluate --task upright --model runs/upright_ppo_0/best_model.zip`` (or ``--agent lqr`` or
``--agent passive``) runs seeded episodes on the native vector env, prints mean +- std return and success rate, and
with ``--out DIR`` writes ``episode.gif`` (the env's renderer) and ``episode.png`` (lean, spin rate, torques and
the track seen from above against the target).
"""

from __future__ import annotations

import argparse
import pickle
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO, SAC, TD3

import rolling_disk_env as rd
from agents.baselines import BASELINES

ALGORITHMS = {"ppo": PPO, "sac": SAC, "td3": TD3}
"""The SB3 algorithms train.py offers, by its --algo name."""
EVAL_SEED = 10_000
"""Evaluation episodes use seeds from here on: training uses others."""


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


def load_agent(path: Path):
    """A saved model (``.zip``) with ``vecnormalize.pkl`` from its folder, if there is one."""
    from stable_baselines3.common.vec_env import VecNormalize

    run = path.parent
    algo = (run / "algo.txt").read_text().strip() if (run / "algo.txt").exists() else "ppo"
    model = ALGORITHMS[algo].load(path, device="cpu")
    normalize = None
    stats = run / "vecnormalize.pkl"
    if stats.exists():
        # VecNormalize.save pickles the statistics without the training envs; normalize_obs needs only those.
        with open(stats, "rb") as handle:
            normalize = pickle.load(handle)
        if not isinstance(normalize, VecNormalize):
            raise ValueError(f"{stats} does not hold VecNormalize statistics")
        normalize.training = False
    return NormalizedPolicy(model, normalize)


def evaluate(agent, name: str, episodes: int = 100, seed: int = EVAL_SEED, **env_kwargs) -> Result:
    """Runs ``episodes`` seeded episodes at once on the native vector env, one episode per sub-environment."""
    env = rd.RollingDiskVectorEnv(num_envs=episodes, max_episode_steps=rd.MAX_EPISODE_STEPS, **env_kwargs)
    observations, _ = env.reset(seed=seed)
    returns = np.zeros(episodes)
    successes = np.zeros(episodes, dtype=bool)
    finished = np.zeros(episodes, dtype=bool)
    while not finished.all():
        actions, _ = agent.predict(observations, deterministic=True)
        observations, rewards, terminated, truncated, infos = env.step(actions)
        returns += np.where(finished, 0.0, rewards)
        ending = (terminated | truncated) & ~finished
        successes |= ending & infos["is_success"]
        finished |= ending
    return Result(name, returns, successes)


def record_episode(agent, seed: int = EVAL_SEED, **env_kwargs) -> dict:
    """One episode on the single env with frames: times, states, torques, frames and the goal."""
    env = gym.make(rd.ENV_ID, render_mode="rgb_array", **env_kwargs)
    observation, info = env.reset(seed=seed)
    unwrapped = env.unwrapped
    limits = np.array(unwrapped.config.max_torque)
    states, torques, frames = [info["state"]], [np.zeros(2)], [env.render()]
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = agent.predict(observation, deterministic=True)
        observation, _, terminated, truncated, info = env.step(action)
        states.append(info["state"])
        torques.append(np.clip(action, -1, 1) * limits)
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
    }


def write_gif(frames: list[np.ndarray], path: Path, fps: int = 25, every: int = 2) -> Path:
    """An animated GIF of every ``every``-th frame (the env runs at 50 frames per second)."""
    from PIL import Image

    images = [Image.fromarray(frame) for frame in frames[::every]]
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    return path


def plot_episode(episode: dict, title: str, path: Path) -> Path:
    """Lean theta(t), spin rate, torques, and the track from above against the target."""
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
    if "radius" in goal:
        angles = np.linspace(0, 2 * np.pi, 200)
        ax.plot(
            goal["cx"] + goal["radius"] * np.cos(angles),
            goal["cy"] + goal["radius"] * np.sin(angles),
            "--",
            color="tab:green",
            label="target circle",
        )
    ax.set(xlabel="x (m)", ylabel="y (m)", title="track from above", aspect="equal")
    ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def make_agent(name_or_path: str, task: str, **env_kwargs):
    """``"passive"``, ``"lqr"`` (the task's baseline) or the path of a saved model."""
    if name_or_path == "passive":
        return PassiveAgent()
    if name_or_path == "lqr":
        return BASELINES[task](task=task, **env_kwargs)
    return load_agent(Path(name_or_path))


def main(argv: list[str] | None = None) -> Result:
    parser = argparse.ArgumentParser(description="Evaluate an agent on RollingDisk-v0.")
    parser.add_argument("--task", choices=sorted(BASELINES), default="upright")
    parser.add_argument("--agent", default="lqr", help='"lqr", "passive" or a model .zip (see --model)')
    parser.add_argument("--model", help="a saved model (.zip); its folder's vecnormalize.pkl is used")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=EVAL_SEED)
    parser.add_argument("--out", type=Path, help="folder for episode.gif and episode.png")
    args = parser.parse_args(argv)
    agent = make_agent(args.model or args.agent, args.task)
    name = args.model or args.agent
    result = evaluate(agent, name, args.episodes, args.seed, task=args.task)
    print("| agent | return (mean +- std) | success |\n|---|---|---|\n| " + " | ".join(result.row()) + " |")
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        episode = record_episode(agent, args.seed, task=args.task)
        print(f"wrote {write_gif(episode['frames'], args.out / 'episode.gif')}")
        print(f"wrote {plot_episode(episode, f'{name} on {args.task}, seed {args.seed}', args.out / 'episode.png')}")
    return result


if __name__ == "__main__":
    main()
