"""Env speed: one ``env.step`` against Gymnasium's classic-control envs, the native vector env against Gymnasium's
``CartPoleVectorEnv`` at every batch size, one thread against numba's threads, and the compile cost.

``python benchmarks/bench_env.py [--quick] [--out DIR]`` writes ``env_speed.md`` and ``env_throughput.png`` to DIR
(default ``benchmarks/results``).

1. One ``env.step`` of every env built with ``gymnasium.make`` and its defaults (so with its wrappers), random
   actions drawn beforehand, reset when an episode ends.
2. The vector envs of ``gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")``, default
   settings, random actions drawn beforehand, Gymnasium's next-step autoreset: env steps per second (N per call),
   every task against ``CartPoleVectorEnv``, for each compile target of :data:`TARGETS`, each in a process of its
   own (numba reads its target when it starts): the host's CPU, AVX2 code (``haswell``'s features, which give AVX2
   code on any x86-64 host, AVX-512 ones included) and the x86-64 baseline (SSE2: two doubles a vector, the width of
   ARM's NEON).
3. Our vector env on one thread (one share) and as it steps by default from
   ``rolling_disk_env.envs.batch.THREADS_FROM`` disks (one share a thread, on the threads or not as its recent steps
   measured faster: ``envs.batch.ThreadChoice``), around ``THREADS_FROM``. ``benchmarks/bench_threads.py`` measures
   the same with another process keeping a core busy.
4. Compile cost, each in a fresh process: ``import rolling_disk_env``; the default env's first ``gym.make``,
   ``reset`` and ``step`` with an empty numba cache (``NUMBA_CACHE_DIR`` set to an empty folder: every kernel
   compiles), then again with that cache warm.

In 1 to 3 the envs compared are timed in turn within each repeat (each sample about the same wall time), so a slow
spell of the shared machine hits all of them; the tables report medians and ratios taken within the run.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import gymnasium as gym
import numba
import numpy as np
from _common import TARGETS, arguments, cpu, in_target, medians_in_turns, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env.envs import batch

SINGLE = {
    "RollingDisk-v0 (upright)": (rd.ENV_ID, {}),
    "RollingDisk-v0 (circle)": (rd.ENV_ID, {"task": "circle"}),
    "CartPole-v1": ("CartPole-v1", {}),
    "Pendulum-v1": ("Pendulum-v1", {}),
    "Acrobot-v1": ("Acrobot-v1", {}),
}
VECTOR = {
    "upright": (rd.ENV_ID, {}),
    "circle": (rd.ENV_ID, {"task": "circle"}),
    "goto": (rd.ENV_ID, {"task": "goto"}),
    "CartPole-v1": ("CartPole-v1", {}),
}
SIZES = (1, 8, 64, 512, 4096, 16384)
THREAD_SIZES = (512, 1024, 2048, 4096, 16384)
TASKS = ("upright", "circle", "goto")
OURS = TASKS

FIRST_STEP = """
import json, sys, time
start = time.perf_counter()
import rolling_disk_env as rd
imported = time.perf_counter()
heavy = [name for name in ("sympy", "numba", "torch") if name in sys.modules]
import gymnasium as gym
env = gym.make(rd.ENV_ID)
made = time.perf_counter()
env.reset(seed=0)
reset = time.perf_counter()
env.step(env.action_space.sample())
stepped = time.perf_counter()
print(json.dumps({"import": imported - start, "make": made - imported, "reset": reset - made,
                  "step": stepped - reset, "first step": stepped - start, "heavy": heavy}))
"""
"""Run in a fresh process: the times (s) from ``import rolling_disk_env`` to the end of the default env's first step,
and the heavy modules the import loaded."""


def _stepper(env_id: str, kwargs: dict, steps: int):
    env = gym.make(env_id, **kwargs)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    env.reset(seed=0)

    def run() -> float:
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        return (time.perf_counter() - start) / steps

    run()
    return run


def single_env_times(steps: int, repeats: int) -> dict[str, float]:
    """Median seconds per ``env.step`` of each env of :data:`SINGLE`."""
    runs = {name: _stepper(env_id, kwargs, steps) for name, (env_id, kwargs) in SINGLE.items()}
    return medians_in_turns(runs, repeats)


def random_actions(space: gym.Space, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` random batched actions of a vector env's ``action_space`` (a Box or a MultiDiscrete), stacked."""
    if isinstance(space, gym.spaces.Box):
        return rng.uniform(space.low, space.high, (count, *space.shape)).astype(space.dtype)
    if isinstance(space, gym.spaces.MultiDiscrete):
        return (space.start + rng.integers(0, space.nvec, (count, *space.shape))).astype(space.dtype)
    raise TypeError(f"no random actions for {space}")


class VectorRun:
    """A vector env stepped with random actions: each call times about ``seconds`` of stepping and returns the env
    steps per second (N per call).

    Args:
        env_id: the id, made with ``vectorization_mode="vector_entry_point"``.
        num_envs: N.
        kwargs: the id's keyword arguments.
        seconds: the wall time of one sample, for which the number of calls is calibrated once.
        threads: split our env into one share a thread, stepped on the threads or not as the env chooses
            (True), or keep it in one share on the calling thread (False); None leaves it to the env.
    """

    def __init__(self, env_id: str, num_envs: int, kwargs: dict, seconds: float, threads: bool | None = None):
        default = batch.THREADS_FROM
        if threads is not None:
            batch.THREADS_FROM = 1 if threads else num_envs + 1
        try:
            self.env = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)
        finally:
            batch.THREADS_FROM = default
        self.num_envs = num_envs
        self.env.reset(seed=0)
        rng = np.random.default_rng(0)
        warm_up = random_actions(self.env.action_space, 20, rng)
        self._step_all(warm_up[:10])  # compiles or loads the steps
        start = time.perf_counter()
        self._step_all(warm_up[10:])
        per_call = (time.perf_counter() - start) / 10
        self.actions = random_actions(self.env.action_space, min(200_000, max(5, round(seconds / per_call))), rng)

    def _step_all(self, actions: np.ndarray) -> None:
        for action in actions:
            self.env.step(action)

    @property
    def threads(self) -> int:
        """The threads our env steps on (1 for other envs)."""
        return self.env.unwrapped._batch.threads if hasattr(self.env.unwrapped, "_batch") else 1

    def __call__(self) -> float:
        start = time.perf_counter()
        self._step_all(self.actions)
        return self.num_envs * len(self.actions) / (time.perf_counter() - start)

    def close(self) -> None:
        self.env.close()


def vector_rates(sizes, seconds: float, repeats: int) -> tuple[dict[str, list[float]], list[int]]:
    """Steps per second of each env of :data:`VECTOR` at each N, and the threads our env has there."""
    rates, threads = {name: [] for name in VECTOR}, []
    for n in sizes:
        runs = {name: VectorRun(env_id, n, kwargs, seconds) for name, (env_id, kwargs) in VECTOR.items()}
        for name, rate in medians_in_turns(runs, repeats).items():
            rates[name].append(rate)
        threads.append(runs["upright"].threads)
        for run in runs.values():
            run.close()
    return rates, threads


def vector_rates_for(target: str, quick: bool) -> tuple[dict[str, list[float]], list[int], str]:
    """:func:`vector_rates` in a fresh process compiled for ``target`` (a key of :data:`TARGETS`), with the CPU line
    of its result file."""
    return in_target(__file__, target, ["--vector-child"] + (["--quick"] if quick else []))


def thread_rows(sizes, seconds: float, repeats: int) -> list[list[object]]:
    """Our vector env on one thread and on numba's threads at each N, both tasks, timed in turns."""
    rows = []
    for n in sizes:
        runs = {
            (task, threads): VectorRun(rd.ENV_ID, n, {"task": task}, seconds, threads=threads)
            for task in TASKS
            for threads in (False, True)
        }
        rates = medians_in_turns(runs, repeats)
        for task in TASKS:
            serial, threaded = rates[(task, False)], rates[(task, True)]
            default = batch.thread_count(n)
            rows.append([n, task, f"{serial / 1e6:.2f}", f"{threaded / 1e6:.2f}", f"{threaded / serial:.2f}", default])
        for run in runs.values():
            run.close()
    return rows


def fresh_process(cache: str) -> dict:
    """:data:`FIRST_STEP` in a fresh Python with ``NUMBA_CACHE_DIR=cache``, plus its wall time from spawn to exit."""
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-c", FIRST_STEP],
        env={**os.environ, "NUMBA_CACHE_DIR": cache},
        capture_output=True,
        text=True,
        check=True,
    )
    return {**json.loads(result.stdout.splitlines()[-1]), "process": time.perf_counter() - start}


def compile_rows(warm_runs: int) -> tuple[list[list[object]], list[str]]:
    """The cold and the warm first step (median of ``warm_runs`` processes), and the heavy modules imported."""
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        cold = fresh_process(cache)
        warm = [fresh_process(cache) for _ in range(warm_runs)]
    keys = ("import", "make", "reset", "step", "first step", "process")
    rows = [
        ["empty cache (cold: compiles)", *(f"{cold[key]:.2f}" for key in keys)],
        [
            f"warm cache (median of {warm_runs})",
            *(f"{statistics.median(run[key] for run in warm):.2f}" for key in keys),
        ],
    ]
    return rows, sorted({name for run in (cold, *warm) for name in run["heavy"]})


def chart(sizes, runs: dict[str, dict[str, list[float]]], path, cpu: str) -> None:
    """Env steps per second against N (log-log): every task and CartPoleVectorEnv, a line each, for each compile
    target of the run (``runs``: target -> rates), CartPole once (its numpy code is the same in every process)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8), facecolor="white")
    markers = {"upright": "o", "circle": "^", "goto": "v"}
    lines = {"host": "-", "AVX2 (haswell)": "--", "x86-64 baseline (SSE2)": ":"}
    for target, rates in runs.items():
        for name, values in rates.items():
            if name == "CartPole-v1":
                continue
            ax.loglog(sizes, values, lines[target], marker=markers[name], markersize=4, label=f"{name}, {target} code")
    first = next(iter(runs.values()))  # CartPole's numpy env is the same in every target's process
    ax.loglog(sizes, first["CartPole-v1"], "k-", lw=2.5, alpha=0.5, label="CartPoleVectorEnv (Gymnasium)")
    ax.set_title(f"Native vector envs against CartPoleVectorEnv, random actions (medians)\n{cpu}", fontsize=8)
    ax.set_xlabel("number of environments N")
    ax.set_ylabel("env steps per second")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6.5, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110, facecolor="white")
    plt.close(fig)


def single_chart(times: dict[str, float], path, cpu: str) -> None:
    """One ``env.step``'s time, a bar per env."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 3.0), facecolor="white")
    names, values = list(times), [times[name] * 1e6 for name in times]
    colors = ["tab:blue" if name.startswith("RollingDisk") else "tab:gray" for name in names]
    ax.barh(names, values, color=colors)
    for y, value in enumerate(values):
        ax.text(value, y, f" {value:.2f} us", va="center", fontsize=8)
    ax.invert_yaxis()
    ax.set_xlim(0, max(values) * 1.2)
    ax.set_xlabel("one env.step through gymnasium.make (us, median)")
    ax.set_title(cpu, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110, facecolor="white")
    plt.close(fig)


def vector_table(rates: dict[str, list[float]], threads_used: list[int]) -> str:
    """The vector table: each env's M steps/s, each task's ratio to CartPoleVectorEnv, our threads."""
    rows = [
        [
            n,
            *(f"{rates[name][i] / 1e6:.3f}" for name in VECTOR),
            *(f"{rates[name][i] / rates['CartPole-v1'][i]:.2f}" for name in OURS),
            threads_used[i],
        ]
        for i, n in enumerate(SIZES)
    ]
    header = ["N", *(f"{name} M steps/s" for name in VECTOR), *(f"{name} / CartPole" for name in OURS), "our threads"]
    return table(header, rows)


def main() -> None:
    args = arguments(__doc__, **{"vector-child": {"action": "store_true", "help": "internal: one target's vector run"}})
    steps, repeats, seconds, warm_runs = (2_000, 3, 0.01, 1) if args.quick else (20_000, 7, 0.2, 3)
    if args.vector_child:
        print(json.dumps([*vector_rates(SIZES, seconds, repeats), cpu()]))
        return

    times = single_env_times(steps, repeats)
    acrobot, cartpole = times["Acrobot-v1"], times["CartPole-v1"]
    single = [
        [name, f"{value * 1e6:.2f}", f"{value / acrobot:.2f}", f"{value / cartpole:.2f}"]
        for name, value in times.items()
    ]
    single_chart(times, args.out / "env_step.png", cpu())
    vector, runs = [], {}
    for target in TARGETS:
        rates, threads_used, target_cpu = vector_rates_for(target, args.quick)
        runs[target] = rates
        vector += [f"### Compiled for {target}: {target_cpu}", "", vector_table(rates, threads_used), ""]
    chart(SIZES, runs, args.out / "env_throughput.png", cpu())
    threads = thread_rows(THREAD_SIZES, seconds, repeats)
    compiled, heavy = compile_rows(warm_runs)

    write_markdown(
        "env_speed",
        "Env speed",
        "python benchmarks/bench_env.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            f"## One `env.step` through `gymnasium.make` (median of {repeats} runs of {steps} steps)",
            "",
            table(["env", "us / step", "ratio to Acrobot-v1", "ratio to CartPole-v1"], single),
            "",
            "![one env.step](env_step.png)",
            "",
            f"## Native vector envs (median of {repeats} samples of about {seconds:g} s each)",
            "",
            *vector,
            "![throughput](env_throughput.png)",
            "",
            f"## Our vector env on one thread and split for {numba.get_num_threads()} numba threads (the env splits"
            f" from N = envs.batch.THREADS_FROM = {batch.THREADS_FROM} and steps the shares on the threads or not, as"
            " its recent steps measured faster)",
            "",
            table(
                ["N", "task", "1 thread M steps/s", "shares M steps/s", "shares / 1 thread", "the env's threads"],
                threads,
            ),
            "",
            "## Compile cost: the default env (`gym.make(rd.ENV_ID)`), each row a fresh process, seconds",
            "",
            table(
                [
                    "numba cache",
                    "`import rolling_disk_env`",
                    "`gym.make`",
                    "`reset`",
                    "first `step`",
                    "import to first step",
                    "process, spawn to exit",
                ],
                compiled,
            ),
            "",
            "Modules among sympy, numba and torch that `import rolling_disk_env` loaded: "
            + (", ".join(heavy) if heavy else "none")
            + ".",
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
