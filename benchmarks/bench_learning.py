"""Learning curves and the benchmark table: the passive disk, the classical baseline and PPO on every task.

``python benchmarks/bench_learning.py [--quick] [--out DIR] [--seeds N] [--tasks T ...]`` writes ``learning.md`` and
``learning_curves.png`` to DIR (default ``benchmarks/results``); the runs go to ``runs/bench_learning/`` (models,
TensorBoard logs).

For each task, PPO is trained by ``agents.training.train`` (what ``train.py`` runs) with the task's block of
``agents/hyperparams/ppo.yml``, with training seeds 0, 1 and 2, one after the other (one torch thread each).
``train``'s periodic evaluations (every 10,000 steps, 10 episodes, deterministic actions; reported through its
``on_evaluation`` callback) give the learning curves: the mean over the seeds, with the range (min to max) shaded,
against environment steps, and the baseline's and the passive disk's level as horizontal lines. ``train``'s final
evaluation gives the table: 100 seeded episodes (seeds 10000 to 10099, the same for every agent) of the trained
policy, the passive disk and the task's baseline (``agents.baselines.BASELINES``); PPO's success rate and mean
return as mean +- std across the training seeds. Wall time is the whole ``train`` call (training, periodic and
final evaluations); CPU time is this process's, which another job on the machine does not inflate.

For ``goto``, a second table places the target: the success rate of the baseline and of each trained policy over
100 episodes per cell, with the target's distance and bearing drawn from a cell's ranges (``task_options``); the
mirror image of a bearing behaves alike, so bearings run from 0 to pi (to the left). Distances under 3 m lie outside
the training range.

``--quick`` trains 20,000 steps per run with two seeds and evaluates 10 episodes: a smoke run.
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

import numpy as np
from _common import ROOT, arguments, table, write_markdown

import rolling_disk_env as rd
from agents.baselines import BASELINES
from agents.evaluate import EVAL_SEED, evaluate, load_agent
from agents.training import HYPERPARAMS, load_hyperparams, train

RUNS = ROOT / "runs" / "bench_learning"
DISTANCES = ((1.0, 2.0), (2.0, 3.0), (3.0, 5.5), (5.5, 8.0))
"""m. The target-placement table's distance bins."""
BEARINGS = {
    "ahead (0 to pi/4)": (0.0, math.pi / 4),
    "beside (pi/4 to 3pi/4)": (math.pi / 4, 3 * math.pi / 4),
    "behind (3pi/4 to pi)": (3 * math.pi / 4, math.pi),
}
"""rad. Its bearing bins, from the initial rolling direction, to the left (the mirror image behaves alike)."""


def run_task(task: str, seeds: list[int], timesteps: int | None, episodes: int) -> dict:
    """Trains PPO on ``task`` once per seed; returns the curves, the final evaluations and the times."""
    block = load_hyperparams(HYPERPARAMS / "ppo.yml", rd.TASK_IDS[task])
    runs = []
    for seed in seeds:
        curve = []
        out = RUNS / f"{task}_ppo_{seed}"
        wall, cpu = time.perf_counter(), time.process_time()
        results = train(
            task,
            "ppo",
            block,
            out,
            timesteps=timesteps,
            seed=seed,
            eval_episodes=episodes,
            progress_bar=False,
            on_evaluation=lambda steps, mean_return, success, curve=curve: curve.append((steps, mean_return, success)),
        )
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        ppo, passive, baseline = results
        print(f"{task}, seed {seed}: {ppo.successes.mean():.0%} success in {wall / 60:.1f} min", flush=True)
        runs.append({"seed": seed, "out": out, "curve": np.array(curve), "ppo": ppo, "wall": wall, "cpu": cpu})
    return {"task": task, "runs": runs, "passive": passive, "baseline": baseline, "steps": ppo.name}


def summary_rows(outcome: dict) -> list[list[object]]:
    """The benchmark table's rows of one task: passive disk, baseline, PPO over the seeds."""
    task, runs = outcome["task"], outcome["runs"]
    rows = []
    for name, result in (
        ("passive disk", outcome["passive"]),
        (f"baseline `{BASELINES[task].__name__}`", outcome["baseline"]),
    ):
        rows.append(
            [
                task,
                name,
                f"{result.successes.mean():.0%}",
                f"{result.returns.mean():.1f} +- {result.returns.std():.1f}",
                "",
            ]
        )
    successes = [100 * run["ppo"].successes.mean() for run in runs]
    returns = [run["ppo"].returns.mean() for run in runs]
    walls = [run["wall"] / 60 for run in runs]
    steps = runs[0]["ppo"].name.split("(trained, ")[-1].rstrip(")")
    rows.append(
        [
            task,
            f"PPO, {steps}, {len(runs)} seeds",
            f"{statistics.mean(successes):.0f}% +- {_std(successes):.0f}%",
            f"{statistics.mean(returns):.1f} +- {_std(returns):.1f}",
            f"{statistics.mean(walls):.1f} min (max {max(walls):.1f})",
        ]
    )
    return rows


def seed_rows(outcome: dict) -> list[list[object]]:
    return [
        [
            outcome["task"],
            run["seed"],
            f"{run['ppo'].successes.mean():.0%}",
            f"{run['ppo'].returns.mean():.1f} +- {run['ppo'].returns.std():.1f}",
            f"{run['wall'] / 60:.1f}",
            f"{run['cpu'] / 60:.1f}",
        ]
        for run in outcome["runs"]
    ]


def _std(values: list[float]) -> float:
    return statistics.stdev(values) if len(values) > 1 else 0.0


def placement_rows(outcome: dict, episodes: int) -> list[list[object]]:
    """Success rates of the goto baseline and of each trained policy, by the target's distance and bearing."""
    rows = []
    agents = [("baseline", None)] + [(f"PPO seed {run['seed']}", run["out"] / "model.zip") for run in outcome["runs"]]
    for distances in DISTANCES:
        for bearing_name, bearings in BEARINGS.items():
            options = {"task": "goto", "task_options": {"distance_range": distances, "bearing_range": bearings}}
            cells = []
            for name, path in agents:
                agent = BASELINES["goto"](**options) if path is None else load_agent(path)
                cells.append(f"{evaluate(agent, name, episodes, **options).successes.mean():.0%}")
            rows.append([f"{distances[0]:g} to {distances[1]:g}", bearing_name, *cells])
    return rows


def plot(outcomes: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(2, len(outcomes), figsize=(4.5 * len(outcomes), 6.5), squeeze=False)
    for column, outcome in enumerate(outcomes):
        curves = [run["curve"] for run in outcome["runs"]]
        length = min(len(curve) for curve in curves)
        steps = curves[0][:length, 0]
        for row, (index, label) in enumerate(((1, "evaluation return"), (2, "success rate"))):
            ax = axes[row, column]
            values = np.array([curve[:length, index] for curve in curves])
            ax.plot(steps, values.mean(axis=0), color="C0", label=f"PPO, mean of {len(curves)} seeds")
            ax.fill_between(steps, values.min(axis=0), values.max(axis=0), color="C0", alpha=0.25, label="PPO, range")
            for name, result, style in (
                ("baseline", outcome["baseline"], "C3"),
                ("passive disk", outcome["passive"], "0.5"),
            ):
                level = result.returns.mean() if index == 1 else result.successes.mean()
                ax.axhline(level, color=style, linestyle="--", label=name)
            ax.set_xlabel("environment steps")
            ax.set_ylabel(label)
            if row == 0:
                ax.set_title(outcome["task"])
            if row == 1:
                ax.set_ylim(-0.03, 1.03)
            ax.grid(alpha=0.3)
    axes[1, 0].legend(fontsize="small", loc="center right")
    figure.suptitle("PPO learning curves (periodic evaluations: 10 episodes every 10,000 steps)")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main() -> None:
    args = arguments(
        __doc__,
        seeds=dict(type=int, default=3, help="training seeds per task (default: %(default)s)"),
        tasks=dict(nargs="+", choices=sorted(rd.TASK_IDS), default=list(rd.TASK_IDS), help="tasks (default: all)"),
    )
    seeds = list(range(2 if args.quick else args.seeds))
    timesteps, episodes = (20_000, 10) if args.quick else (None, 100)
    outcomes = [run_task(task, seeds, timesteps, episodes) for task in args.tasks]
    plot(outcomes, args.out / "learning_curves.png")
    summary = table(
        ["task", "agent", "success", "return", "wall time per run"],
        [row for outcome in outcomes for row in summary_rows(outcome)],
    )
    per_seed = table(
        ["task", "seed", "success", "return (mean +- std over episodes)", "wall time (min)", "CPU time (min)"],
        [row for outcome in outcomes for row in seed_rows(outcome)],
    )
    sections = [
        f"{episodes} evaluation episodes per agent (seeds {EVAL_SEED} to {EVAL_SEED + episodes - 1}, deterministic "
        f"actions); PPO trained with `python train.py --task <task>`'s settings (`agents/hyperparams/ppo.yml`), "
        f"seeds {', '.join(map(str, seeds))}. Passive disk and baseline: success rate, and mean +- std return over "
        "the episodes; PPO: mean +- std across the seeds of each seed's success rate and mean return.",
        "",
        summary,
        "",
        "![learning curves](learning_curves.png)",
        "",
        "## Each training seed",
        "",
        per_seed,
    ]
    goto = next((outcome for outcome in outcomes if outcome["task"] == "goto"), None)
    if goto is not None:
        header = ["target distance (m)", "bearing", "baseline", *(f"PPO seed {run['seed']}" for run in goto["runs"])]
        sections += [
            "",
            "## goto: where the target lies",
            "",
            f"Success rate over {episodes} episodes per cell, the target drawn in the cell: its distance, and its "
            "bearing from the initial rolling direction, to the left (to the right is the mirror image). Training "
            "draws 3 to 8 m at any bearing.",
            "",
            table(header, placement_rows(goto, episodes)),
        ]
    command = "python benchmarks/bench_learning.py" + (" --quick" if args.quick else "")
    write_markdown(
        "learning", "Learning curves: passive disk, classical baseline and PPO per task", command, sections, args.out
    )


if __name__ == "__main__":
    main()
