"""When rolling holds: the friction coefficient the contact needs, and the normal force, along the paper's scenarios and
over evaluation episodes of each task under the classical baseline and a trained agent.

``python benchmarks/bench_rolling_limits.py [--quick] [--out DIR] [--runs DIR]`` writes ``rolling_limits.md``. The
model assumes that the contact rolls without slipping and stays on the plane; a real disk with friction coefficient
mu does what the env shows only while ``required_friction = |lambda| / N <= mu`` and ``N > 0``. Trained agents are
read from ``<runs>/<task>_ppo_0/best_model.zip`` (``python train.py --task <task>`` writes them); a task without
one is reported for the baseline and the passive disk only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from _common import arguments, table, write_markdown

import rolling_disk_env as rd
from agents.baselines import BASELINES
from agents.evaluate import EVAL_SEED, PassiveAgent, load_agent
from rolling_disk_env.paper import scenarios

COLUMNS = ["motion", "episodes", "max mu", "99th pct mu", "median mu", "min N (N)", "steps with N <= 0"]


def _row(name: str, episodes: int | str, required: np.ndarray, normal: np.ndarray) -> list[object]:
    return [
        name,
        episodes,
        f"{required.max():.3f}",
        f"{np.percentile(required, 99):.3f}",
        f"{np.median(required):.3f}",
        f"{normal.min():.1f}",
        int(np.sum(normal <= 0)),
    ]


def scenario_rows(quick: bool) -> list[list[object]]:
    rows = []
    for scenario in scenarios():
        duration = scenario.duration / (4 if quick else 1)
        _, states = rd.simulate(scenario.state0, duration, 0.01, method="dop853", rtol=1e-10, atol=1e-10)
        rows.append(_row(scenario.title, "-", rd.required_friction(states), rd.normal_force(states)))
    return rows


def episode_rows(agent, name: str, task: str, episodes: int) -> list[object]:
    """The contact's needs over every step of ``episodes`` seeded episodes, until each ends."""
    env = rd.RollingDiskVectorEnv(num_envs=episodes, max_episode_steps=rd.MAX_EPISODE_STEPS, task=task)
    observations, _ = env.reset(seed=EVAL_SEED)
    finished = np.zeros(episodes, dtype=bool)
    required, normal = [], []
    while not finished.all():
        actions, _ = agent.predict(observations, deterministic=True)
        observations, _, terminated, truncated, infos = env.step(actions)
        live = ~finished
        required.append(infos["required_friction"][live])
        normal.append(infos["normal_force"][live])
        finished |= terminated | truncated
    return _row(f"{task}, {name}", episodes, np.concatenate(required), np.concatenate(normal))


def main() -> None:
    args = arguments(__doc__, runs={"type": Path, "default": Path("runs"), "help": "folder of train.py's runs"})
    episodes = 10 if args.quick else 100
    rows = scenario_rows(args.quick)
    for task in sorted(BASELINES):
        agents = {"passive disk": PassiveAgent(), f"baseline {BASELINES[task].__name__}": BASELINES[task](task=task)}
        model = args.runs / f"{task}_ppo_0" / "best_model.zip"
        if model.exists():
            agents[f"PPO ({model})"] = load_agent(model)
        rows += [episode_rows(agent, name, task, episodes) for name, agent in agents.items()]
    write_markdown(
        "rolling_limits",
        "When rolling holds: the friction the contact needs",
        "python benchmarks/bench_rolling_limits.py",
        [
            "mu is `required_friction = |lambda| / N`, the friction coefficient a real contact needs to roll as the "
            "model does (a contact with less slips); N is the normal force (the disk lifts off where N <= 0). "
            f"Episodes: seeded from {EVAL_SEED}, every step until each ends.",
            "",
            table(COLUMNS, rows),
        ],
        args.out,
    )


if __name__ == "__main__":
    main()
