"""Compile time: how long each configuration's kernels take to compile with nothing cached, on the CPU and for a GPU.

``python benchmarks/bench_compile.py [--quick] [--all] [--gpu] [--root DIR] [--out DIR]`` writes ``compile.md`` to
DIR (default ``benchmarks/results``).

*CPU*: each configuration (task x contact x integrator) in a fresh process with an empty ``NUMBA_CACHE_DIR`` (and an
empty ``HOME``): a single env's first ``reset`` and ``step`` (what compiles there), then a vector env's of 8 disks
(what it compiles beyond that), then a vector env's of 4,096 disks, its ``reset`` and 8 steps (where there are several
cores, it splits into a share a thread, and its reset and steps 4 to 6 run on the threads: what that compiles beyond the
rest, with the disks' own time), each timed in wall seconds and in the CPU seconds of the process (user + system,
which a shared machine's other jobs disturb less). By default a sample of the grid: every task with ``rk4``, the
other integrators on ``upright``, the ``"sliding"`` and ``"coulomb"`` contacts on ``upright`` and ``circle``;
``--all`` runs the whole grid. ``--root`` times another checkout of the repository (the code before a change).

*GPU* (``--gpu``, where numba-cuda is installed; no GPU needed): the kernels of :data:`GPU_KERNELS` of each task,
compiled to PTX for sm_90 by NVVM (``numba.cuda.compile_ptx``, as ``tests/test_gpu_build.py`` does), in a fresh
process each, then the PTX to sm_90 machine code by nvJitLink (``cuda.core.Linker``: the ptxas of the CUDA wheels, as
at a kernel's first launch), whose report gives each thread's registers, stack frame and spills.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import ROOT, arguments, table, write_markdown

from rolling_disk_env.tasks import TASKS as TASK_CLASSES

CPU_CHILD = r"""
import json, resource, sys, time

def cpu():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime

import gymnasium as gym, numpy as np
import rolling_disk_env as rd

kwargs = json.loads(sys.argv[1])
times = {}
start, spent = time.perf_counter(), cpu()
env = gym.make("RollingDisk-v0", **kwargs)
env.reset(seed=0)
env.step(np.zeros(env.action_space.shape, dtype=np.float32))
times["single"] = (time.perf_counter() - start, cpu() - spent)
start, spent = time.perf_counter(), cpu()
envs = gym.make_vec("RollingDisk-v0", num_envs=8, vectorization_mode="vector_entry_point", **kwargs)
envs.reset(seed=0)
envs.step(np.zeros(envs.action_space.shape, dtype=np.float32))
times["vector"] = (time.perf_counter() - start, cpu() - spent)
start, spent = time.perf_counter(), cpu()
envs = gym.make_vec("RollingDisk-v0", num_envs=4096, vectorization_mode="vector_entry_point", **kwargs)
envs.reset(seed=0)
for _ in range(8):  # ThreadChoice tries each way for 3 steps: the calling thread first, then the threads
    envs.step(np.zeros(envs.action_space.shape, dtype=np.float32))
times["threads"] = (time.perf_counter() - start, cpu() - spent)
print(json.dumps(times))
"""

GPU_CHILD = r"""
import json, re, sys, time
from types import SimpleNamespace
import numba, numpy as np
from numba import cuda
sys.path.insert(0, ".")
from rolling_disk_env.envs.config import EnvConfig
from tests.test_gpu_build import H100, _arguments
from rolling_disk_env._generated import cuda as kernels

task, name = sys.argv[1], sys.argv[2]
from rolling_disk_env.tasks import TASKS
own = TASKS[task].contact is not None  # a task under a contact of its own (ice) takes its defaults
contact = {"contact": "coulomb", "friction_coefficient": 0.2} if "contact" in name and not own else {}
config = EnvConfig.from_kwargs(task=task, **contact)
arguments = _arguments(config, name)
numba.cuda.dispatcher.get_current_device = lambda: SimpleNamespace(compute_capability=H100)
start = time.perf_counter()
ptx, _ = cuda.compile_ptx(getattr(kernels, f"{task}_{name}"), (numba.typeof(arguments),), cc=H100)
nvvm = time.perf_counter() - start

from cuda.core import Linker, LinkerOptions, ObjectCode
start = time.perf_counter()
linker = Linker(ObjectCode.from_ptx(ptx.encode()), options=LinkerOptions(arch="sm_90", verbose=True))
linker.link("cubin")
ptxas = time.perf_counter() - start
log = linker.get_info_log()
registers = int(re.findall(r"Used (\d+) registers", log)[-1])
frame = r"(\d+) bytes stack frame, (\d+) bytes spill stores, (\d+) bytes spill loads"
stack, stores, loads = map(int, re.findall(frame, log)[-1])
print(json.dumps([nvvm, ptxas, registers, stack, stores, loads]))
"""

TASKS = tuple(TASK_CLASSES)
INTEGRATORS = ("euler", "symplectic_euler", "rk4", "dopri5")
GPU_KERNELS = ("reset", "reset_contact", "step_rk4", "step_rk4_training", "step_contact", "step_contact_hybrid")
"""The CUDA kernels timed of each task (those it has): its resets, the default step in the full and the training
set of outputs, the steps of the sliding and Coulomb contacts."""


def configurations(everything: bool, quick: bool) -> list[dict]:
    """The configurations timed: ``gym.make`` keyword arguments."""
    if quick:
        return [{"task": "upright"}]
    grid = [{"task": task, "integrator": integrator} for task in TASKS for integrator in INTEGRATORS]
    grid += [
        {"task": task, "contact": contact, "friction_coefficient": 0.2}
        for task in TASKS
        for contact in ("sliding", "coulomb")
        if TASK_CLASSES[task].contact is None  # not a task whose contact is its own (ice)
    ]
    if everything:
        return grid
    return [
        kwargs
        for kwargs in grid
        if kwargs.get("integrator") == "rk4"
        or (kwargs["task"] == "upright" and "integrator" in kwargs)
        or (kwargs["task"] in ("upright", "circle") and "contact" in kwargs)
    ]


def child(code: str, args: list[str], root: Path, python: str = sys.executable) -> object:
    """Runs ``code`` in a fresh ``python`` in ``root`` with empty numba caches; the JSON of its last line."""
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as home:
        environment = {**os.environ, "NUMBA_CACHE_DIR": cache, "HOME": home, "PYTHONPATH": str(root)}
        result = subprocess.run(
            [python, "-c", code, *args], cwd=root, env=environment, capture_output=True, text=True, check=False
        )
    if result.returncode:
        raise RuntimeError(f"{args} failed:\n{result.stderr[-3000:]}")
    return json.loads(result.stdout.splitlines()[-1])


def name_of(kwargs: dict) -> str:
    contact = kwargs.get("contact") or TASK_CLASSES[kwargs["task"]].contact or "rolling"
    return f"{kwargs['task']}, {contact}, {kwargs.get('integrator', 'rk4')}"


def main() -> None:
    args = arguments(
        __doc__,
        all={"action": "store_true", "help": "the whole grid of configurations (default: a sample)"},
        gpu={"action": "store_true", "help": "also the CUDA kernels' NVVM and ptxas times (needs numba-cuda)"},
        root={"type": Path, "default": ROOT, "help": "the checkout to time (default: this one)"},
        python={"default": sys.executable, "help": "the Python of --gpu's runs (one with numba-cuda)"},
    )
    root = args.root.resolve()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    rows = []
    started = time.perf_counter()
    for kwargs in configurations(args.all, args.quick):
        times = child(CPU_CHILD, [json.dumps(kwargs)], root)
        figures = [f"{value:.1f}" for key in ("single", "vector", "threads") for value in times[key]]
        rows.append([name_of(kwargs), *figures])
        print(rows[-1], flush=True)
    sections = [
        __doc__.split("\n\n", 2)[2].strip(),
        "",
        f"Timed: {root if root != ROOT else f'this checkout ({commit.stdout.strip()})'}; "
        f"{time.perf_counter() - started:.0f} s in all.",
        "",
        "## CPU",
        "",
        table(
            [
                "task, contact, integrator",
                "single env's reset + step: wall (s)",
                "CPU (s)",
                "then a vector env's: wall (s)",
                "CPU (s)",
                "then one of 4,096 disks on threads: wall (s)",
                "CPU (s)",
            ],
            rows,
        ),
    ]
    if args.gpu:
        python = args.python
        gpu_rows = []
        generated = (root / "rolling_disk_env" / "_generated" / "cuda.py").read_text()
        for task in TASKS if not args.quick else ("upright",):
            for name in GPU_KERNELS:
                if f"def {task}_{name}(" not in generated:  # a task without kernels of its own, or of a contact
                    continue
                nvvm, ptxas, registers, stack, stores, loads = child(GPU_CHILD, [task, name], root, python)
                gpu_rows.append([f"{task}_{name}", f"{nvvm:.1f}", f"{ptxas:.1f}", registers, stack, stores, loads])
                print(gpu_rows[-1], flush=True)
        header = [
            "kernel",
            "NVVM to PTX (s)",
            "ptxas to sm_90 (s)",
            "registers a thread",
            "stack frame (bytes)",
            "spill stores (bytes)",
            "spill loads (bytes)",
        ]
        sections += ["", "## GPU: compiled for sm_90 (NVVM, then nvJitLink's ptxas)", "", table(header, gpu_rows)]
    write_markdown(
        "compile",
        "Compile time with nothing cached",
        "python benchmarks/bench_compile.py" + (" --all" if args.all else "") + (" --gpu" if args.gpu else ""),
        sections,
        args.out,
    )


if __name__ == "__main__":
    main()
