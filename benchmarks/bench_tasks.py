"""Every task's vector env against CartPoleVectorEnv at N = 16,384, and what randomized disks and the training set of
outputs cost or save there.

``python benchmarks/bench_tasks.py [--quick] [--out DIR]`` writes ``task_speed.md`` to DIR (default
``benchmarks/results``).

For each compile target of :data:`TARGETS` (the host's CPU, and AVX2 code), in a process of its own: the vector env of
every task (``gymnasium.make_vec(id, num_envs=16384, vectorization_mode="vector_entry_point")``, its defaults: on two
cores, a share a thread) and ``CartPoleVectorEnv``, then each task with randomized disks (``params_ranges``: mass,
gravity and radius; and the friction coefficient under ``ice``'s Coulomb contact), and each task with the training set
of outputs (``info_keys="training"``), all timed in turn within each repeat (random actions drawn beforehand,
next-step autoreset, samples of about 0.2 s). Each repeat gives each env's steps per second and its ratio to
CartPoleVectorEnv's in that repeat; the table holds the medians of those over the repeats.
"""

from __future__ import annotations

import json
import statistics

from _common import arguments, cpu, in_target, table, write_markdown
from bench_env import VectorRun

import rolling_disk_env as rd

N = 16384
RANDOMIZED = {"mass": (4.0, 6.0), "gravity": (9.0, 10.6), "radius": (0.8, 1.2)}
"""The disks' ranges of the randomized rows (and under Coulomb's contact, mu from 0.05 to 0.2)."""
MEASURED = ("host", "AVX2 (haswell)")


def runs(seconds: float) -> dict[str, VectorRun]:
    """Every env of a target's table, by row name."""
    found = {"CartPole-v1": VectorRun("CartPole-v1", N, {}, seconds)}
    for task, env_id in rd.TASK_IDS.items():
        found[task] = VectorRun(env_id, N, {}, seconds)
        ranges = dict(RANDOMIZED, **({"friction_coefficient": (0.05, 0.2)} if task == "ice" else {}))
        found[f"{task}, randomized"] = VectorRun(env_id, N, {"params_ranges": ranges}, seconds)
        found[f"{task}, training outputs"] = VectorRun(env_id, N, {"info_keys": "training"}, seconds)
    return found


def child(quick: bool) -> dict:
    """The medians of a target's rows: steps per second and ratio to CartPoleVectorEnv, per repeat."""
    repeats, seconds = (2, 0.02) if quick else (5, 0.2)
    envs = runs(seconds)
    rates = {name: [] for name in envs}
    ratios = {name: [] for name in envs}
    for _ in range(repeats):
        sample = {name: run() for name, run in envs.items()}
        for name, rate in sample.items():
            rates[name].append(rate)
            ratios[name].append(rate / sample["CartPole-v1"])
    return {
        "rates": {name: statistics.median(values) for name, values in rates.items()},
        "ratios": {name: statistics.median(values) for name, values in ratios.items()},
        "repeats": repeats,
        "cpu": cpu(),
    }


def main() -> None:
    args = arguments(__doc__, **{"child": {"action": "store_true", "help": "internal: one target's rows"}})
    if args.child:
        print(json.dumps(child(args.quick)))
        return
    sections = [__doc__.split("\n\n", 2)[2].strip(), ""]
    for target in MEASURED:
        found = in_target(__file__, target, ["--child"] + (["--quick"] if args.quick else []))
        rates, ratios = found["rates"], found["ratios"]
        rows = [
            [
                task,
                f"{rates[task] / 1e6:.2f}",
                f"{ratios[task]:.2f}",
                f"{ratios[f'{task}, randomized']:.2f}",
                f"{rates[task] / rates[f'{task}, randomized']:.2f}",
                f"{ratios[f'{task}, training outputs']:.2f}",
                f"{rates[f'{task}, training outputs'] / rates[task]:.2f}",
            ]
            for task in rd.TASK_IDS
        ]
        sections += [
            f"## Compiled for {target}: {found['cpu']}",
            "",
            f"CartPoleVectorEnv: {rates['CartPole-v1'] / 1e6:.2f} M steps/s (median of {found['repeats']}).",
            "",
            table(
                [
                    "task",
                    "M steps/s",
                    "/ CartPole",
                    "randomized / CartPole",
                    "randomized: time / off",
                    "training outputs / CartPole",
                    "training outputs: speed-up",
                ],
                rows,
            ),
            "",
        ]
    write_markdown(
        "task_speed",
        f"Every task's vector env at N = {N:,}",
        "python benchmarks/bench_tasks.py" + (" --quick" if args.quick else ""),
        sections,
        args.out,
    )


if __name__ == "__main__":
    main()
