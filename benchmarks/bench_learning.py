"""The learning benchmark: every task x trainer x seeds, with interval estimates.

Commands (``python benchmarks/bench_learning.py <command> ...``):

* ``cell --task T --trainer X [--seeds S ...] [--times K]``: trains one cell, trainer X on task T, once per seed, and
  writes its record, ``<out>/learning/<X>/<T>.json`` (with K times the block's budget: ``<T>_x<K>.json``); a cell may
  run in parts, ``--seeds 0 1 2`` and ``--seeds 3 4`` at once on two cores: a part keeps the record's runs of other
  seeds where they ran with the same settings;
* ``table [--jobs 2] [--tasks T ...]``: every cell whose record is missing (or describes other settings), then
  ``report``; the trainers whose library is not installed here are named with the command that runs them (rsl_rl's in
  a venv of the ``[gpu]`` extra, rejax's of the ``[jax]`` extra);
* ``headroom``: what the headroom task allows (:func:`headroom`), ``<out>/learning/headroom.json``;
* ``report``: the report of the records there are: ``<out>/learning.md`` (the manual's page of the learning
  benchmark: its charts, its table, then how to reproduce it) and its charts; in ``benchmarks/results``, then the
  pages that quote it (``pages.py``: the README's and the manual's task tables).

``--quick`` (any command) is a smoke run in another folder: two seeds, 4,096 steps (rsl_rl: one iteration of its 4,096
disks x 16 steps), times ``--times``, 10 evaluation episodes.

Trainers (:data:`TRAINERS`): SB3's PPO and SAC (``agents.training.train``, what ``train.py`` runs), rsl_rl's PPO on
the torch vector env over the CPU engine (``agents.device_training``, ``train.py --device cpu``) and rejax's PPO
compiled with the JAX env into one XLA program, its seeds ``vmap``ped in that program (``agents.jax_training``); each
with its hyperparameter file's block of the task, whose budget of environment steps is the run's (never cut here),
5 seeds a cell (10 vmapped). Each run ends with the same evaluation: 100 seeded episodes (seeds 10000 to 10099) of the
Gymnasium vector env, deterministic actions; its success rate and mean return are the run's scores. A cell's record
holds every run's scores, its learning curve (the trainer's periodic evaluations against environment steps and wall
time), its wall and CPU time, the machine, the device, the commit, and a hash of the settings it ran with (the block,
the evaluation): ``tests/test_results.py`` flags a record whose settings are no longer the files'.

The report (:mod:`agents.reporting`): per cell the interquartile mean (IQM) over the runs with a 95% percentile
bootstrap interval, of the success rate and of the return normalized per task from the passive disk (0) to the
classical baseline (1), or to the best agent where the baseline does not beat the passive disk by a tenth of the range
(the table says which); over the tasks, the IQM with a stratified bootstrap interval; performance profiles; learning
curves against steps and against wall time (rejax's training returns at its end: its wall time spread evenly over its
steps, and labelled so).
"""

from __future__ import annotations

import argparse
import fcntl
import functools
import json
import os
import resource
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from importlib.util import find_spec
from pathlib import Path

import numpy as np
import pages
from _common import RESULTS, ROOT, commit, cpu, machine, table
from _common import settings_hash as common_hash

import rolling_disk_env as rd
from agents import reporting
from agents.baselines import BASELINES
from agents.evaluate import EVAL_SEED, PassiveAgent, evaluate
from agents.training import HYPERPARAMS, load_hyperparams

RUNS = ROOT / "runs" / "bench_learning"
EPISODES = 100
"""Evaluation episodes of every run, and of the references."""


@dataclass(frozen=True)
class Trainer:
    """A trainer of the table: its name in it, the hyperparameter file its blocks come from, the seeds of a cell,
    the Python module it needs, and the extra that installs it."""

    label: str
    file: str
    seeds: int
    needs: str
    extra: str


TRAINERS = {
    "sb3-ppo": Trainer("PPO (SB3)", "ppo.yml", 5, "stable_baselines3", "train"),
    "sb3-sac": Trainer("SAC (SB3)", "sac.yml", 5, "stable_baselines3", "train"),
    "rsl_rl-ppo": Trainer("PPO (rsl_rl, CPU engine)", "rsl_rl_ppo.yml", 5, "rsl_rl", "gpu"),
    "rejax-ppo": Trainer("PPO (rejax, JAX, 10 seeds vmapped)", "rejax_ppo.yml", 10, "rejax", "jax"),
}
"""The table's columns, by their command-line name."""
JAX_TASKS = tuple(task for task in rd.TASK_IDS if task != "ice")
"""The tasks the JAX env runs (not ice: it has no Coulomb contact)."""
HEADROOM = {"recovery_sparse": "recovery"}
"""The headroom task, and its twin with a dense reward (the same starts, dynamics, observation and success)."""
HEADROOM_TIMES = 4
"""The headroom task's longer budget: this many times its hyperparameter file's."""


def cells() -> list[tuple[str, str]]:
    """Every cell of the table: (trainer, task)."""
    return [
        (trainer, task) for trainer in TRAINERS for task in rd.TASK_IDS if trainer != "rejax-ppo" or task in JAX_TASKS
    ]


def block(trainer: str, task: str) -> dict:
    """The hyperparameter block of a cell, as its file gives it."""
    return load_hyperparams(HYPERPARAMS / TRAINERS[trainer].file, rd.TASK_IDS[task])


def settings_hash(trainer: str, task: str, times: int = 1, quick: bool = False) -> str:
    """The sha256 of what a cell's runs depend on but the code: its block, the evaluation's episodes and seeds (and
    the multiple of the block's budget, where it is not 1; and ``quick``, which shortens both)."""
    settings = {
        "trainer": trainer,
        "task": task,
        "block": block(trainer, task),
        "episodes": EPISODES,
        "seed": EVAL_SEED,
    }
    settings = settings if times == 1 else {**settings, "times": times}
    return common_hash({**settings, "quick": True} if quick else settings)


def runs_folder(out: Path) -> Path:
    """Where the runs' folders go (their models and logs; not committed): ``runs/bench_learning`` for the committed
    results' cells, ``<out>/runs`` for those of another ``--out``."""
    return RUNS if out.resolve() == RESULTS.resolve() else out / "runs"


def record_path(out: Path, trainer: str, task: str, times: int = 1) -> Path:
    """A cell's record: ``<task>.json``, or ``<task>_x<times>.json`` for a multiple of its budget."""
    return out / "learning" / trainer / (f"{task}.json" if times == 1 else f"{task}_x{times}.json")


def run_cell(trainer: str, task: str, seeds: list[int], out: Path, quick: bool, times: int = 1) -> Path:
    """Trains a cell once per seed (with ``times`` its block's budget) and writes its record."""
    started = time.time()
    runs = RUNNERS[trainer](task, seeds, quick, times, runs_folder(out))
    record = {
        "trainer": trainer,
        "task": task,
        "budget": runs[0]["steps"],
        "budget_times": times,
        "episodes": 10 if quick else EPISODES,
        "settings_hash": settings_hash(trainer, task, times, quick),
        "commit": commit(),
        "machine": machine(),
        "cpu": cpu(),
        "device": "cpu",
        "date": time.strftime("%Y-%m-%d"),
        "wall_s": time.time() - started,
        "runs": runs,
    }
    path = record_path(out, trainer, task, times)
    path.parent.mkdir(parents=True, exist_ok=True)
    folder = os.open(path.parent, os.O_RDONLY)
    try:
        fcntl.flock(folder, fcntl.LOCK_EX)  # the parts of a cell that end at once write one after the other
        earlier = json.loads(path.read_text()) if path.exists() else None
        if earlier and earlier["settings_hash"] == record["settings_hash"]:
            kept = [run for run in earlier["runs"] if run["seed"] not in seeds]
            record["runs"] = sorted(kept + runs, key=lambda run: run["seed"])
            record["wall_s"] += earlier["wall_s"] if kept else 0.0  # the parts' compute, summed
        path.write_text(json.dumps(record, indent=1) + "\n")
    finally:
        os.close(folder)
    print(
        f"{trainer} on {task}: {[round(run['success'], 2) for run in record['runs']]} success, wrote {path}", flush=True
    )
    return path


def _scores(result) -> dict:
    """A run's final evaluation as a record keeps it."""
    return {
        "success": float(result.successes.mean()),
        "mean_return": float(result.returns.mean()),
        "returns": [round(float(value), 4) for value in result.returns],
    }


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _run_sb3(algo: str):
    def run(task: str, seeds: list[int], quick: bool, times: int, folder: Path) -> list[dict]:
        from agents.training import train

        hyperparams = block(f"sb3-{algo}", task)
        runs = []
        for seed in seeds:
            curve = []
            began, cpu_began = time.perf_counter(), _cpu_seconds()

            def listen(steps, mean_return, success, curve=curve, began=began):
                curve.append([steps, time.perf_counter() - began, mean_return, success])

            out = folder / f"sb3-{algo}" / f"{task}{'' if times == 1 else f'_x{times}'}_{seed}"
            shutil.rmtree(out, ignore_errors=True)  # a run's logs are its own
            results = train(
                task,
                algo,
                hyperparams,
                out,
                timesteps=times * (4096 if quick else int(hyperparams["n_timesteps"])),
                seed=seed,
                eval_episodes=10 if quick else EPISODES,
                progress_bar=False,
                on_evaluation=listen,
            )
            steps = int(results[0].name.split("(trained, ")[1].split(" ")[0])
            wall, cpu_s = time.perf_counter() - began, _cpu_seconds() - cpu_began
            runs.append(
                {"seed": seed, "steps": steps, "wall_s": wall, "cpu_s": cpu_s, "curve": curve, **_scores(results[0])}
            )
        return runs

    return run


def _run_rsl_rl(task: str, seeds: list[int], quick: bool, times: int, folder: Path) -> list[dict]:
    from agents.device_training import train_on_device

    hyperparams = block("rsl_rl-ppo", task)
    budget = hyperparams["num_envs"] * hyperparams["num_steps_per_env"] * hyperparams["max_iterations"]
    runs = []
    for seed in seeds:
        out = folder / "rsl_rl-ppo" / f"{task}{'' if times == 1 else f'_x{times}'}_{seed}"
        shutil.rmtree(out, ignore_errors=True)  # its TensorBoard log is the run's curve
        began, cpu_began = time.perf_counter(), _cpu_seconds()
        results = train_on_device(
            task,
            hyperparams,
            out,
            device="cpu",
            timesteps=times * (4096 * 16 if quick else budget),
            seed=seed,
            eval_episodes=10 if quick else EPISODES,
        )
        wall, cpu_s = time.perf_counter() - began, _cpu_seconds() - cpu_began
        steps = int(results[0].name.rsplit(", ", 1)[1].split(" ")[0])
        curve = _tensorboard_curve(out / "tb", wall, steps)
        runs.append(
            {"seed": seed, "steps": steps, "wall_s": wall, "cpu_s": cpu_s, "curve": curve, **_scores(results[0])}
        )
    return runs


def _tensorboard_curve(folder: Path, wall: float, steps: int) -> list[list[float]]:
    """rsl_rl's learning curve from its TensorBoard log: the mean return of the training episodes that ended by each
    iteration (``Train/mean_reward``, rsl_rl's buffer of the latest ones) and the success rate of those of the
    iteration (``/success_rate``), at the iteration's environment steps and wall time (from the log's times); empty
    where no episode ended (a run shorter than an episode)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(folder)).Reload()
    tags = events.Tags()["scalars"]
    if "Train/mean_reward" not in tags:
        return []
    returns = events.Scalars("Train/mean_reward")
    success = {event.step: event.value for event in events.Scalars("/success_rate")} if "/success_rate" in tags else {}
    first, iterations = returns[0].wall_time, max(1, returns[-1].step + 1)
    return [
        [(event.step + 1) * steps / iterations, event.wall_time - first, event.value, success.get(event.step)]
        for event in returns
    ]


def _run_rejax(task: str, seeds: list[int], quick: bool, times: int, folder: Path) -> list[dict]:
    from agents.jax_training import train_seeds_in_jax

    hyperparams = block("rejax-ppo", task)
    hyperparams = {**hyperparams, "total_timesteps": times * int(hyperparams["total_timesteps"])}
    if quick:
        hyperparams = {**hyperparams, "total_timesteps": times * 4096, "eval_freq": 2048}
    began, cpu_began = time.perf_counter(), _cpu_seconds()
    trained = train_seeds_in_jax(task, hyperparams, seeds)
    steps, every = int(hyperparams["total_timesteps"]), trained["eval_freq"]
    runs = []
    for seed, policy, returns in zip(seeds, trained["policies"], trained["returns"]):
        result = evaluate(policy, "rejax", 10 if quick else EPISODES, task=task)
        # One program trains every seed: its wall time, spread evenly over each run's steps (so labelled).
        per_step = trained["train_s"] / steps
        curve = [[(j + 1) * every, (j + 1) * every * per_step, float(value), None] for j, value in enumerate(returns)]
        runs.append({"seed": seed, "steps": steps, "curve": curve, **_scores(result)})
    wall, cpu_s = time.perf_counter() - began, _cpu_seconds() - cpu_began
    for run in runs:
        run.update(wall_s=wall, cpu_s=cpu_s, compile_s=trained["compile_s"], train_s=trained["train_s"])
    return runs


RUNNERS = {"sb3-ppo": _run_sb3("ppo"), "sb3-sac": _run_sb3("sac"), "rsl_rl-ppo": _run_rsl_rl, "rejax-ppo": _run_rejax}


def references(out: Path, quick: bool) -> dict:
    """The passive disk's and the classical baseline's scores per task (``<out>/learning/references.json``, computed
    once a task: they do not learn)."""
    path = out / "learning" / "references.json"
    found = json.loads(path.read_text()) if path.exists() else {}
    if all(task in found for task in rd.TASK_IDS):
        return found
    episodes = 10 if quick else EPISODES
    for task in (task for task in rd.TASK_IDS if task not in found):
        passive = evaluate(PassiveAgent(), "passive", episodes, task=task)
        baseline = evaluate(BASELINES[task](task=task), BASELINES[task].__name__, episodes, task=task)
        found[task] = {"passive": _scores(passive), "baseline": {"name": BASELINES[task].__name__, **_scores(baseline)}}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({**found, "commit": commit(), "machine": machine()}, indent=1) + "\n")
    return found


def headroom(out: Path, quick: bool) -> Path:
    """Shows what the headroom tasks (:data:`HEADROOM`) allow, where a trainer's PPO fails: the planner on the exact
    model (:class:`agents.planner.CEMPlanner`, planning with the dense twin's reward) and the policies SB3's PPO
    trained on the twin (its cell's runs, which must have run here), each over the evaluation's seeded episodes;
    writes ``<out>/learning/headroom.json``."""
    from agents.evaluate import load_agent
    from agents.planner import CEMPlanner, evaluate_planner

    episodes = 10 if quick else EPISODES
    found = {}
    for task, dense in HEADROOM.items():
        twin = record_path(out, "sb3-ppo", dense)
        seeds = [run["seed"] for run in json.loads(twin.read_text())["runs"]] if twin.exists() else []
        models = [runs_folder(out) / "sb3-ppo" / f"{dense}_{seed}" / "model.zip" for seed in seeds]
        if not seeds or not all(model.exists() for model in models):
            raise SystemExit(
                f"the runs of the dense twin {dense!r} are missing here: run python benchmarks/bench_learning.py "
                f"cell --task {dense} --trainer sb3-ppo{' --quick' if quick else ''} first"
            )
        began = time.perf_counter()
        # The planner scores its plans by the reward; the dense twin's episodes are this task's (same seeds, starts
        # and success rule).
        planner = evaluate_planner(CEMPlanner(task=dense), "CEMPlanner", episodes)
        planner_s = time.perf_counter() - began
        transfer = [
            {"seed": seed, **_scores(evaluate(load_agent(model), "PPO", episodes, task=task))}
            for seed, model in zip(seeds, models)
        ]
        found[task] = {
            "dense": dense,
            "planner": {"name": "CEMPlanner", "wall_s": planner_s, **_scores(planner)},
            "dense_policies": transfer,
        }
    path = out / "learning" / "headroom.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({**found, "commit": commit(), "machine": machine()}, indent=1) + "\n")
    print(f"wrote {path}", flush=True)
    return path


def load_records(out: Path) -> dict:
    """Every cell's record there is, by (trainer, task)."""
    found = {}
    for trainer, task in cells():
        path = record_path(out, trainer, task)
        if path.exists():
            found[trainer, task] = json.loads(path.read_text())
    return found


def report(out: Path, quick: bool) -> None:
    """Writes ``learning.md`` with its charts, and (not ``quick``) the manual's page, from the records."""
    records, refs = load_records(out), references(out, quick)
    if not records:
        raise SystemExit(f"no records in {out / 'learning'}: run the cells first")
    ladder = sorted(
        rd.TASK_IDS,
        key=lambda task: (
            -np.mean([run["success"] for run in records.get(("sb3-ppo", task), {"runs": [{"success": 0}]})["runs"]])
        ),
    )
    scales = {}
    for task in rd.TASK_IDS:
        agents = [run["mean_return"] for (_, t), record in records.items() if t == task for run in record["runs"]]
        best = max(agents, default=refs[task]["baseline"]["mean_return"])
        scales[task] = reporting.normalization(
            refs[task]["passive"]["mean_return"], refs[task]["baseline"]["mean_return"], best
        )
    rows, aggregate = [], {}
    for task in ladder:
        low, high, reference = scales[task]
        ref = refs[task]
        row = [
            task,
            f"{ref['passive']['success']:.0%}",
            f"{ref['baseline']['name']} {ref['baseline']['success']:.0%}",
            reference,
        ]
        for trainer in TRAINERS:
            record = records.get((trainer, task))
            if record is None:
                row.append("-")
                continue
            success = np.array([run["success"] for run in record["runs"]])
            score = reporting.normalized([run["mean_return"] for run in record["runs"]], low, high)
            s_low, s_high = reporting.percentile_interval(success)
            n_low, n_high = reporting.percentile_interval(score)
            row.append(
                f"{reporting.iqm(success):.0%} [{s_low:.0%}, {s_high:.0%}]; "
                f"{reporting.iqm(score):.2f} [{n_low:.2f}, {n_high:.2f}]"
            )
            aggregate.setdefault(trainer, {})[task] = (success, score)
        rows.append(row)
    header = ["task (ladder order)", "passive", "baseline", "1 =", *(TRAINERS[t].label for t in TRAINERS)]
    totals = []
    for trainer, by_task in aggregate.items():
        successes = [values[0] for values in by_task.values()]
        scores = [values[1] for values in by_task.values()]
        s_low, s_high = reporting.stratified_interval(successes)
        n_low, n_high = reporting.stratified_interval(scores)
        totals.append(
            [
                TRAINERS[trainer].label,
                len(by_task),
                f"{reporting.iqm(np.concatenate(successes)):.0%} [{s_low:.0%}, {s_high:.0%}]",
                f"{reporting.iqm(np.concatenate(scores)):.2f} [{n_low:.2f}, {n_high:.2f}]",
            ]
        )
    compute = [
        [
            TRAINERS[trainer].label,
            task,
            record["budget"],
            len(record["runs"]),
            f"{np.median([run['wall_s'] for run in record['runs']]) / 60:.1f}",
            f"{record['wall_s'] / 60:.1f}",
            record["device"],
            record["cpu"],
            record["commit"],
        ]
        for (trainer, task), record in sorted(records.items())
    ]
    total_wall = sum(record["wall_s"] for record in records.values()) / 3600
    headroom_rows = headroom_table(out, records)
    charts(records, refs, scales, ladder, out)
    missing = sum((trainer, task) not in records for trainer, task in cells())
    sections = [
        "![success and normalized return, per task and over the tasks](learning_iqm.png)",
        "",
        "![performance profiles](learning_profiles.png)",
        "",
        "![learning curves](learning_curves.png)",
        "",
        "## The table",
        "",
        f"Per cell: the IQM over the training seeds, with its 95% bootstrap interval, of the success rate over "
        f"{EPISODES} seeded evaluation episodes (seeds {EVAL_SEED} to {EVAL_SEED + EPISODES - 1}), then of the mean "
        "return normalized from the passive disk (0) to the column `1 =` (the classical baseline, or the best agent "
        "where the baseline does not beat the passive disk by a tenth of the range). Tasks in the ladder's order: by "
        "SB3's PPO's success, highest first.",
        "",
        table(header, rows),
        *(
            [
                "",
                f"`-`: {missing} of the {len(cells())} cells have not run here (a cell's command is under How to "
                "reproduce; no budget is cut to make the table fit a time).",
            ]
            if missing
            else []
        ),
        "",
        "Over the tasks (the IQM of every run, a stratified bootstrap interval):",
        "",
        table(["trainer", "tasks", "success", "normalized return"], totals),
        *(
            [
                "",
                "## Headroom",
                "",
                f"The tasks where PPO fails at its budget, trained again with {HEADROOM_TIMES} times that budget, and "
                "what their dynamics allow: the planner on the exact model "
                "(`agents.planner.CEMPlanner`, reading the disk's state) and the policies SB3's PPO trained on the "
                "twin with a dense reward (the same starts, dynamics, observation and success), over the same "
                "seeded episodes. Success: the IQM over the runs (the planner: one) with its 95% bootstrap "
                "interval; run: a training run's median wall time, the planner's for all its episodes.",
                "",
                table(["task", "agent", "steps a run", "runs", "run (min)", "success"], headroom_rows),
            ]
            if headroom_rows
            else []
        ),
        "",
        "## Compute",
        "",
        f"The cells here: {total_wall:.1f} h of compute on this machine (their wall times summed). They ran "
        "in two queues at once, each pinned to a core of its own with one thread (`OMP_NUM_THREADS=1 "
        "NUMBA_NUM_THREADS=1`; rejax's XLA on its core), as `table --jobs 2` runs them. Per cell: its budget of "
        "environment steps (from the trainer's hyperparameter file), seeds, the median wall time of a run and the "
        "cell's, and where it ran.",
        "",
        table(
            ["trainer", "task", "steps a run", "seeds", "run (min)", "cell (min)", "device", "CPU", "commit"], compute
        ),
    ]
    quick_flag = " --quick" if quick else ""
    sections += [
        "",
        "## How to reproduce",
        "",
        f"The whole table (the cells missing or run with other settings, two at once): `python "
        f"benchmarks/bench_learning.py table{quick_flag}`; one cell: `python benchmarks/bench_learning.py cell --task "
        f"<task> --trainer <trainer>{quick_flag}` (trainers: {', '.join(f'`{name}`' for name in TRAINERS)}; "
        "rsl_rl's in a venv of the `[gpu]` extra, rejax's of the `[jax]` extra); the report of the records: `python "
        f"benchmarks/bench_learning.py report{quick_flag}`. The headroom section: `python benchmarks/bench_learning.py "
        f"cell --task <task> --trainer sb3-ppo --times {HEADROOM_TIMES}{quick_flag}` for each task of "
        f"{', '.join(f'`{task}`' for task in HEADROOM)}, then `python benchmarks/bench_learning.py "
        f"headroom{quick_flag}` (after the dense twin's cell). Each cell's record, with every run's scores and "
        "learning curve, is `learning/<trainer>/<task>.json` beside this page (`<task>_x<times>.json` for a longer "
        "budget); the passive disk's and the baselines' scores are `learning/references.json`, the headroom's "
        "evaluations `learning/headroom.json`.",
        "",
        machine(),
        "",
        f"Commit: {commit()} (the report's; each cell's record names the commit it ran at).",
    ]
    path = out / "learning.md"
    title = "# The learning benchmark: tasks x trainers x seeds"
    summary = (
        "Every task of the ladder, trained by each trainer with its hyperparameter file's budget, 5 seeds a cell "
        "(10 vmapped for rejax), scored over the same 100 seeded evaluation episodes, with interval estimates "
        "(`agents/reporting.py`)."
    )
    path.write_text("\n".join([title, "", summary, "", *sections]).rstrip() + "\n")
    print(path.read_text())
    if path.resolve() == pages.LEARNING:  # the pages that quote it follow it: the task tables
        pages.main()


def charts(records: dict, refs: dict, scales: dict, ladder: list[str], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    trainers = [trainer for trainer in TRAINERS if any(t == trainer for t, _ in records)]
    figure, axes = plt.subplots(1, 2, figsize=(13, 4.5))
    width = 0.8 / max(1, len(trainers))
    for k, trainer in enumerate(trainers):
        for axis, index in ((axes[0], "success"), (axes[1], "score")):
            points, lows, highs, places = [], [], [], []
            for j, task in enumerate(ladder):
                record = records.get((trainer, task))
                if record is None:
                    continue
                values = _values(record, scales[task], index)
                low, high = reporting.percentile_interval(values)
                points.append(reporting.iqm(values))
                lows.append(points[-1] - low)
                highs.append(high - points[-1])
                places.append(j + (k - (len(trainers) - 1) / 2) * width)
            axis.bar(places, points, width, yerr=[lows, highs], capsize=2, label=TRAINERS[trainer].label)
    for axis, label in (
        (axes[0], "success rate (IQM, 95% interval)"),
        (axes[1], "normalized return (IQM, 95% interval)"),
    ):
        axis.set_xticks(range(len(ladder)), ladder, rotation=20, ha="right")
        axis.set_ylabel(label)
        axis.axhline(1.0, color="0.5", lw=0.8, ls=":")
        axis.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize="small")
    figure.suptitle("Each task, each trainer: IQM over the seeds")
    figure.tight_layout()
    figure.savefig(out / "learning_iqm.png", dpi=100)
    plt.close(figure)

    figure, axis = plt.subplots(figsize=(6.5, 4.5))
    thresholds = np.linspace(0.0, 1.2, 61)
    for trainer in trainers:
        scores = np.concatenate(
            [_values(record, scales[task], "score") for (t, task), record in records.items() if t == trainer]
        )
        axis.plot(thresholds, reporting.performance_profile(scores, thresholds), label=TRAINERS[trainer].label)
    axis.set(xlabel="normalized return tau", ylabel="fraction of runs with score > tau", title="Performance profiles")
    axis.grid(alpha=0.3)
    axis.legend(fontsize="small")
    figure.tight_layout()
    figure.savefig(out / "learning_profiles.png", dpi=100)
    plt.close(figure)

    figure, axes = plt.subplots(2, len(ladder), figsize=(3.2 * len(ladder), 6), squeeze=False)
    for j, task in enumerate(ladder):
        low, high, _ = scales[task]
        for trainer in trainers:
            record = records.get((trainer, task))
            if record is None:
                continue
            curves = [
                np.array([point[:3] for point in run["curve"]], dtype=float) for run in record["runs"] if run["curve"]
            ]
            if not curves:
                continue
            length = min(len(curve) for curve in curves)
            stacked = np.stack([curve[:length] for curve in curves])
            normalized = reporting.normalized(stacked[:, :, 2], low, high)
            label = TRAINERS[trainer].label + (" (wall time spread)" if trainer == "rejax-ppo" else "")
            for row, column in ((0, 0), (1, 1)):
                x = stacked[:, :, column].mean(axis=0) / (60 if column else 1)
                axes[row, j].plot(x, reporting.iqm(normalized, axis=0), label=label)
        axes[0, j].set(title=task, xlabel="environment steps")
        axes[1, j].set(xlabel="wall time (min)")
        for row in range(2):
            axes[row, j].grid(alpha=0.3)
    axes[0, 0].set_ylabel("normalized return (IQM)")
    axes[1, 0].set_ylabel("normalized return (IQM)")
    labelled = {label: line for axis in axes[1] for line, label in zip(*axis.get_legend_handles_labels())}
    if labelled:  # a quick run may have no curve of the first task
        axes[1, 0].legend(labelled.values(), labelled.keys(), fontsize="x-small")
    figure.suptitle("Learning curves: each trainer's own periodic evaluations")
    figure.tight_layout()
    figure.savefig(out / "learning_curves.png", dpi=90)
    plt.close(figure)


def headroom_table(out: Path, records: dict) -> list[list]:
    """The rows of the report's headroom section: each trainer's runs of a headroom task at its budget and at
    :data:`HEADROOM_TIMES` times it, then what ``headroom.json`` holds (the planner, the dense twin's policies)."""
    path = out / "learning" / "headroom.json"
    shown = json.loads(path.read_text()) if path.exists() else {}
    rows = []

    def row(task, agent, steps, runs, minutes):
        success = np.array([run["success"] for run in runs])
        low, high = reporting.percentile_interval(success)
        rows.append([task, agent, steps, len(runs), minutes, f"{reporting.iqm(success):.0%} [{low:.0%}, {high:.0%}]"])

    for task, dense in HEADROOM.items():
        for trainer in TRAINERS:
            longer = record_path(out, trainer, task, HEADROOM_TIMES)
            if (trainer, task) not in records or not longer.exists():
                continue
            for times, record in ((1, records[trainer, task]), (HEADROOM_TIMES, json.loads(longer.read_text()))):
                minutes = f"{np.median([run['wall_s'] for run in record['runs']]) / 60:.1f}"
                row(task, f"{TRAINERS[trainer].label}, {times}x its budget", record["budget"], record["runs"], minutes)
        if task in shown:
            planner = shown[task]["planner"]
            name = f"{planner['name']} on the exact model, planning with {dense}'s reward"
            row(task, name, "-", [planner], f"{planner['wall_s'] / 60:.1f}")
            row(task, f"PPO (SB3) trained on {dense}'s dense reward", "-", shown[task]["dense_policies"], "-")
    return rows


def _values(record: dict, scale: tuple, which: str) -> np.ndarray:
    if which == "success":
        return np.array([run["success"] for run in record["runs"]])
    return reporting.normalized([run["mean_return"] for run in record["runs"]], scale[0], scale[1])


def table_command(out: Path, quick: bool, jobs: int, tasks: list[str]) -> None:
    """Runs every missing (or stale) cell of ``tasks`` whose trainer is installed, ``jobs`` at once, then
    :func:`report`; fails naming the cells that failed. With several jobs, each cell's process is pinned to a core
    of its own (the ``k``-th queue to the ``k``-th core this process may use) with one thread (``OMP_NUM_THREADS=1``,
    ``NUMBA_NUM_THREADS=1``), so that the cells' wall times are those of one core, not of each other's threads."""
    pending, skipped = [], []
    for trainer, task in (cell for cell in cells() if cell[1] in tasks):
        path = record_path(out, trainer, task)
        current = path.exists() and json.loads(path.read_text())["settings_hash"] == settings_hash(
            trainer, task, quick=quick
        )
        if current:
            continue
        if find_spec(TRAINERS[trainer].needs) is None:
            skipped.append((trainer, task))
        else:
            pending.append((trainer, task))
    cores = sorted(os.sched_getaffinity(0))
    environment = {**os.environ, **({"OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"} if jobs > 1 else {})}
    running: dict[int, tuple[subprocess.Popen, str, str]] = {}  # by queue
    failed = []

    def reap(wait: bool) -> None:
        for queue, (process, trainer, task) in list(running.items()):
            if (process.wait() if wait else process.poll()) is not None:
                del running[queue]
                if process.returncode:
                    failed.append(f"{trainer} on {task} (exit {process.returncode})")

    for trainer, task in pending:
        while len(running) >= jobs:
            time.sleep(5)
            reap(wait=False)
        queue = min(set(range(jobs)) - set(running))
        core = {cores[queue % len(cores)]} if jobs > 1 else None
        command = [sys.executable, __file__, "cell", "--task", task, "--trainer", trainer, "--out", str(out)]
        process = subprocess.Popen(
            [*command, *(["--quick"] if quick else [])],
            env=environment,
            preexec_fn=None if core is None else functools.partial(os.sched_setaffinity, 0, core),
        )
        running[queue] = (process, trainer, task)
    reap(wait=True)
    for trainer, task in skipped:
        print(
            f"skipped {trainer} on {task}: {TRAINERS[trainer].needs} is not installed; in a venv of the "
            f"[{TRAINERS[trainer].extra}] extra: python benchmarks/bench_learning.py cell --task {task} "
            f"--trainer {trainer}",
            flush=True,
        )
    report(out, quick)
    if failed:
        raise SystemExit(f"bench_learning.py: cells that failed: {', '.join(failed)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=("cell", "table", "headroom", "report"))
    parser.add_argument("--task", choices=list(rd.TASK_IDS), help="cell: the task")
    parser.add_argument(
        "--tasks", choices=list(rd.TASK_IDS), nargs="+", help="table: only these tasks' cells (default: every task)"
    )
    parser.add_argument("--trainer", choices=list(TRAINERS))
    parser.add_argument("--seeds", type=int, nargs="+", help="the cell's seeds (default: 0 to the trainer's count)")
    parser.add_argument(
        "--times", type=int, default=1, help="cell: this many times the block's budget (default: %(default)s)"
    )
    parser.add_argument("--jobs", type=int, default=2, help="cells at once (default: %(default)s)")
    parser.add_argument(
        "--quick", action="store_true", help="a smoke run: 2 seeds, 4096 steps (rsl_rl: 65536), 10 episodes"
    )
    parser.add_argument("--out", type=Path, help="folder of the results (default: benchmarks/results)")
    args = parser.parse_args()
    out = args.out or (RUNS / "quick" if args.quick else RESULTS)
    from agents import show_compiling

    show_compiling()
    if args.command == "cell":
        if args.task is None or args.trainer is None:
            parser.error("cell needs --task and --trainer")
        if (args.trainer, args.task) not in cells():
            parser.error(f"{args.trainer} does not run task {args.task!r} (JAX has no Coulomb contact)")
        seeds = args.seeds or list(range(2 if args.quick else TRAINERS[args.trainer].seeds))
        run_cell(args.trainer, args.task, seeds, out, args.quick, args.times)
    elif args.command == "table":
        table_command(out, args.quick, args.jobs, args.tasks or list(rd.TASK_IDS))
    elif args.command == "headroom":
        headroom(out, args.quick)
    else:
        report(out, args.quick)


if __name__ == "__main__":
    main()
