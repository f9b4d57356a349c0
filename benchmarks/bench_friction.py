"""How often each task's agents would slide on a real surface, and what sliding does to their success.

``python benchmarks/bench_friction.py [--quick] [--out DIR] [--model TASK=PATH ...]`` writes ``friction.md``. For each
task, its classical controller (and each trained model given with ``--model``) runs the 100 seeded evaluation episodes
of ``python -m agents.evaluate`` (all at once on the native vector env), first on the paper's ideal rolling contact,
whose ``info["required_friction"]`` says what friction coefficient each step needs, then under ``contact="coulomb"``
at mu = 0.2, 0.4 and 0.7 (a rubber wheel on wet, dusty and dry ground, roughly), where it slides when it needs more.
The table gives, per mu: the share of episodes whose rolling contact needed more than mu at some step (they would
slide), the success under Coulomb's contact, and the share of disk-steps spent sliding there.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from _common import arguments, table, write_markdown

from agents.evaluate import evaluate, load_agent, make_agent
from rolling_disk_env.tasks import TASKS

MUS = (0.2, 0.4, 0.7)
"""The surfaces' friction coefficients."""


def survey(agent, name: str, task: str, episodes: int, **env_kwargs) -> tuple[float, np.ndarray, float]:
    """Runs the evaluation episodes: success rate, each episode's peak friction need (rolling contact) and the share
    of disk-steps that slid."""
    peak, sliding, steps = np.zeros(episodes), np.zeros(episodes), np.zeros(episodes)

    def on_step(infos: dict, running: np.ndarray) -> None:
        peak[running] = np.maximum(peak[running], infos["required_friction"][running])
        sliding[running] += infos["sliding"][running]
        steps[running] += 1

    result = evaluate(agent, name, episodes, on_step=on_step, task=task, **env_kwargs)
    return result.successes.mean(), peak, sliding.sum() / steps.sum()


def rows_for(agent, name: str, task: str, episodes: int) -> list[list[object]]:
    """The agent's row per mu: would slide, success under Coulomb, steps sliding; after its rolling success."""
    success, peak, _ = survey(agent, name, task, episodes)
    rows = []
    for mu in MUS:
        coulomb_success, _, slid = survey(agent, name, task, episodes, contact="coulomb", friction_coefficient=mu)
        rows.append(
            [
                task,
                name,
                f"{100 * success:.0f}%",
                mu,
                f"{100 * np.mean(peak > mu):.0f}%",
                f"{100 * coulomb_success:.0f}%",
                f"{100 * slid:.1f}%",
            ]
        )
    return rows


def model_argument(value: str) -> tuple[str, Path]:
    task, _, path = value.partition("=")
    if task not in TASKS or not path:
        raise SystemExit(f"--model takes TASK=PATH with TASK one of {sorted(TASKS)}, got {value!r}")
    if not Path(path).is_file():
        raise SystemExit(f"--model {value}: no file {path}")
    return task, Path(path)


def training_command(model: Path) -> str:
    """How a model was trained: its run folder's ``command.txt`` (train.py's), the interpreter's path left out."""
    path = model.parent / "command.txt"
    if not path.exists():
        return f"`{model}`"
    _, _, arguments = path.read_text().strip().partition(" ")
    return f"`python {arguments}`"


def main() -> None:
    args = arguments(
        __doc__,
        model={
            "action": "append",
            "default": [],
            "type": model_argument,
            "metavar": "TASK=PATH",
            "help": "a trained model (best_model.zip of train.py) to survey on TASK; repeatable",
        },
    )
    episodes = 10 if args.quick else 100
    trained = [f"- `{path.parent.name}`: {training_command(path)}" for _, path in args.model]
    rows = []
    for task in sorted(TASKS):
        rows += rows_for(make_agent("baseline", task), "classical", task, episodes)
        for model_task, path in args.model:
            if model_task == task:
                rows += rows_for(load_agent(path), str(path.parent.name), task, episodes)
    write_markdown(
        "friction",
        "Would the agents slide? Success on real surfaces",
        "python benchmarks/bench_friction.py " + " ".join(f"--model {t}={p}" for t, p in args.model),
        [
            f"{episodes} seeded evaluation episodes per row (seeds from 10000, as `agents.evaluate`).",
            "",
            "Per agent and friction coefficient mu: its success on the ideal rolling contact; the share of episodes "
            "whose rolling contact needed more than mu at some step (`info['required_friction']`: these would "
            'slide); its success under `contact="coulomb"` with that mu, where it slides when it needs more, '
            "and the share of its disk-steps that slid there.",
            "",
            table(
                ["task", "agent", "success, rolling", "mu", "would slide", "success, coulomb", "steps sliding"], rows
            ),
            "",
            "Agents: `classical`, the task's controller of `agents/baselines.py`; the trained ones, by run folder, "
            "from:"
            if trained
            else "Agents: `classical`, the task's controller of `agents/baselines.py`.",
            "",
            *trained,
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
