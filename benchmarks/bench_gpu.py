"""GPU throughput: disk-steps per second of the CUDA kernels, physics only, fused and through the env's step, beside
the CPU vector env on all the host's cores, Gymnasium's ``CartPoleVectorEnv`` and a JAX CartPole on the same GPU, in one
run; and what a step costs beyond its arithmetic: launches, reads of the device, bytes, memory, registers, seeding.

``python benchmarks/bench_gpu.py [--quick] [--out DIR] [--budget S]`` writes ``gpu.md``, ``gpu.json`` and ``gpu.png``
to DIR (default ``benchmarks/results``), each figure also printed as it is measured (``--budget``: seconds, after
which the rows not yet measured are marked so). Needs the ``[gpu]`` extra and a CUDA GPU; under numba-cuda's simulator
(``NUMBA_ENABLE_CUDASIM=1``) ``--quick`` runs it as a smoke test on the CPU, where only the host time of a step with
its launches stubbed out (section 6) means something.

1. Physics only: the generated model's RK4 step (``_generated/kernels.py``, ``state_rk4_step_from``: the CPU's code,
   compiled by numba-cuda) for :data:`PHYSICS_STEPS` steps of 0.02 s a launch, a GPU thread a disk, its state in
   registers; and each task's fused step (``_generated/<task>.py``'s ``step_rk4_share``: torques, RK4, contact,
   termination, rewards, observation) :data:`FUSED_STEPS` times a launch: the ceiling of an env step.
2. The env's step: ``gym.make_vec(..., device="cuda")``, random actions drawn on the GPU beforehand, next-step
   autoreset, torch tensors out, timed over whole steps with ``torch.cuda.synchronize()``.
3. Anchors, timed in the same run: the numpy vector env on the host's cores, ``CartPoleVectorEnv``, and CartPole's
   equations (Gymnasium's, Euler) in JAX, ``vmap`` over the batch and ``lax.scan`` over :data:`PHYSICS_STEPS` steps,
   jitted for the GPU, where JAX sees one.
4. The Coulomb contact against the rolling one on the same batch (``bench_contact``'s: upright disks rolling faster
   than they need, every tenth under the full spin torque), on the GPU and the host, so that the two ratios compare.
5. ``reset(seed=0)`` (every disk's PCG64 state derived from its seed, then the reset kernel), the memory a disk takes
   on the GPU and the largest N that fits, the bytes a step moves per disk and the share of the memory bandwidth
   that reaches, the registers and local memory of each kernel, and per configuration the launches, reads of the
   device and bytes crossing between host and device in a step (counted at the package's entry points).
6. The host time of one ``step()`` at N = 64 with the launches stubbed out: the Python a step runs, the guide where no
   GPU is at hand.

Each figure is the median of :data:`REPEATS` timed runs after a warm-up run (which compiles).
"""

from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import time

import gymnasium as gym
import numpy as np
import torch
from _common import arguments, cpu, table, write_markdown
from bench_contact import BATCH_CONTACTS, BATCH_SETUP

import rolling_disk_env as rd
from rolling_disk_env import gpu
from rolling_disk_env._generated import circle, goto, kernels, upright

cuda = gpu.cuda
"""numba-cuda's ``numba.cuda`` (:mod:`rolling_disk_env.gpu` checks that it is numba-cuda's)."""
SIZES = (2**10, 2**16, 2**20, 2**22)
"""N: 1,024 to 4,194,304 disks."""
CPU_LIMIT = 2**16
"""The largest N of the CPU anchors (their step takes seconds beyond)."""
CONTACT_SIZE = 2**16
"""N of the contact rows."""
PHYSICS_STEPS, FUSED_STEPS, ENV_STEPS, REPEATS = 100, 20, 20, 5
TASKS = {"upright": upright, "circle": circle, "goto": goto}
DT = 0.02


def _physics(states, steps):
    """``steps`` RK4 steps of 0.02 s of disk k's state (a column of ``states``), zero torque, the paper's disk."""
    k = cuda.grid(1)
    if k < states.shape[1]:
        x = (
            states[0, k],
            states[1, k],
            states[2, k],
            states[3, k],
            states[4, k],
            states[5, k],
            states[6, k],
            states[7, k],
        )
        for _ in range(steps):
            x = kernels.state_rk4_step_from(x, kernels.angles(x), DT, 0.0, 0.0, 5.0, 9.81, 1.0)
        for j in range(8):
            states[j, k] = x[j]


def _fused(task_module):
    """A kernel running the task's fused RK4 step ``count`` times a launch (disk k: thread k), no resets."""
    share = task_module.step_rk4_share

    def fused(arguments, count):
        actions, batch, setup, out, resets, _ = arguments
        k = cuda.grid(1)
        if k < batch[0].shape[1]:
            for _ in range(count):
                share(np.int64(k), actions, batch, setup, out, resets)

    return cuda.jit(fused)


def make(task: str, n: int, device: str | None = "cuda", **kwargs):
    """The ids' vector env of ``task`` for ``n`` disks, on ``device`` (None: the numpy env), reset with seed 0."""
    extra = {} if device is None else {"device": device}
    envs = gym.make_vec(rd.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", task=task, **extra, **kwargs)
    envs.reset(seed=0)
    return envs


def _synchronize() -> None:
    if not gpu.SIMULATED:
        torch.cuda.synchronize()


def _median_rate(run, disk_steps: int) -> float:
    """Disk-steps per second of ``run()`` (which does ``disk_steps``), median of :data:`REPEATS` after a warm-up."""
    run()
    _synchronize()
    times = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        run()
        _synchronize()
        times.append(time.perf_counter() - start)
    return disk_steps / statistics.median(times)


def physics_rate(n: int, steps: int) -> float:
    kernel = cuda.jit(_physics)
    states = np.zeros((8, n))
    states[3], states[5], states[7] = 0.3, 2.0, 1.0  # leaning, rolling, turning
    device_states = gpu.to_device(states)
    return _median_rate(lambda: gpu.launch(kernel, n, device_states, steps), n * steps)


def fused_rate(task: str, n: int, steps: int) -> float:
    envs = make(task, n)
    envs.step(torch.zeros((n, 2), device=envs.unwrapped.device))  # zero actions in the batch's buffer
    batch = envs.unwrapped._batch
    batch.mask.zero_()  # no reset
    kernel, arguments = _fused(TASKS[task]), batch.step_arguments
    rate = _median_rate(lambda: gpu.launch(kernel, n, arguments, steps), n * steps)
    envs.close()
    return rate


def env_rate(task: str, n: int, steps: int, device: str | None, **kwargs) -> float:
    """The env's step: on the GPU (``device="cuda"``) or the numpy vector env (None), random actions."""
    envs = make(task, n, device, **kwargs)
    if device is None:
        actions = np.random.default_rng(0).uniform(-1, 1, (steps, n, 2)).astype(np.float32)
    else:
        actions = torch.rand((steps, n, 2), device=envs.unwrapped.device) * 2 - 1

    def run():
        for step in range(steps):
            envs.step(actions[step])

    rate = _median_rate(run, n * steps)
    envs.close()
    return rate


def driven_rate(n: int, device: str | None, contact: dict, steps: int) -> tuple[float, float]:
    """Disk-steps/s of ``bench_contact``'s driven batch under ``contact`` (every tenth disk spun by the full spin
    torque), and the fraction of the disk-steps that slid."""
    envs = make(BATCH_SETUP["task"], n, device, initial_ranges=BATCH_SETUP["initial_ranges"], **contact)
    action = np.zeros((n, 2), np.float32)
    action[::10, 0] = 1.0
    if device is not None:
        action = torch.from_numpy(action).to(envs.unwrapped.device)
    sliding = []

    def run():
        for _ in range(steps):
            sliding.append(envs.step(action)[-1]["sliding"].sum())

    rate = _median_rate(run, n * steps)
    slid = float(sum(float(count) for count in sliding)) / (n * len(sliding))
    envs.close()
    return rate, slid


def reset_seconds(n: int, device: str | None) -> float:
    """Seconds of ``reset(seed=0)`` of a fresh env of ``n`` disks (``upright``), after a warm-up at N = 64."""
    make("upright", 64, device).close()
    extra = {} if device is None else {"device": device}
    envs = gym.make_vec(rd.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **extra)
    _synchronize()
    start = time.perf_counter()
    envs.reset(seed=0)
    _synchronize()
    seconds = time.perf_counter() - start
    envs.close()
    return seconds


def memory_per_disk(task: str, n: int) -> float:
    """Bytes of GPU memory an env of ``task`` takes a disk, at ``n`` disks (the device's free memory before and
    after: torch's tensors and the arrays numba-cuda copied there)."""
    torch.cuda.synchronize()
    torch.cuda.empty_cache()
    free = torch.cuda.mem_get_info()[0]
    envs = make(task, n)
    envs.step(torch.zeros((n, 2), device=envs.unwrapped.device))
    torch.cuda.synchronize()
    taken = free - torch.cuda.mem_get_info()[0]
    envs.close()
    return taken / n


def step_bytes(envs) -> float:
    """Bytes a step moves per disk, counted from what the kernels and copies touch: the batch's own arrays (lanes,
    goals, step counts) read and written, the outputs written (the final ones, of the disks that end, not counted),
    the actions copied into the batch's buffer and read, the fresh outputs copied, the check's reads."""
    batch, n = envs.unwrapped._batch, envs.num_envs
    per_disk = lambda array: array.nbytes / n  # noqa: E731
    own = sum(per_disk(array) for array in batch._device[0][:3])
    out = sum(per_disk(array) for array in batch.out.shares[1:])
    fresh = per_disk(batch._fresh)
    actions = per_disk(batch.actions)
    return 2 * own + out + 2 * fresh + 3 * actions + 2 + 4  # + ended, mask and the rewards' row read


def peak_bandwidth() -> float | None:
    """The GPU's memory bandwidth (bytes/s) from its memory clock and bus width, where the driver reports them."""
    try:
        device = cuda.get_current_device()
        return 2.0 * device.MEMORY_CLOCK_RATE * 1e3 * device.GLOBAL_MEMORY_BUS_WIDTH / 8
    except Exception:  # attributes a driver may not report
        return None


def kernel_resources(envs) -> dict[str, tuple[int, int]]:
    """Registers and local memory (bytes) a thread of each kernel the env launched."""
    found = {}
    for launch in envs.unwrapped._batch._prepared():
        if launch is not None and launch.compiled is not None:
            name = getattr(launch.function, "__name__", "kernel")
            found[name] = (int(launch.compiled.regs_per_thread), int(launch.compiled.local_mem_per_thread))
    return found


def crossings(task: str, mode: str, contact: dict) -> dict[str, int]:
    """Per step (of 4, after a first), the kernel launches, the reads of the device (the status word, and any read
    of a tensor on the host) and the copies through :func:`gpu.to_device` and :func:`gpu.to_host`."""
    from unittest import mock

    envs = make(task, 256, autoreset_mode=mode, **contact)
    actions = torch.zeros((256, 2), device=envs.unwrapped.device)
    envs.step(actions)
    counts: dict[str, int] = {}

    def counted(name, function):
        def call(*args, **kwargs):
            counts[name] = counts.get(name, 0) + 1
            return function(*args, **kwargs)

        return call

    patches = [
        mock.patch.object(gpu.Launch, "__call__", counted("launches", gpu.Launch.__call__)),
        mock.patch.object(gpu.DeviceBatch, "_read_status", counted("reads", gpu.DeviceBatch._read_status)),
        mock.patch.object(gpu, "to_device", counted("copies", gpu.to_device)),
        mock.patch.object(gpu, "to_host", counted("copies", gpu.to_host)),
    ]
    patches += [
        mock.patch.object(torch.Tensor, name, counted("reads", getattr(torch.Tensor, name)))
        for name in ("__bool__", "item", "cpu", "tolist")
    ]
    for patch in patches:
        patch.start()
    try:
        for _ in range(4):
            envs.step(actions)
    finally:
        for patch in patches:
            patch.stop()
    envs.close()
    return {key: value // 4 for key, value in counts.items()}


def host_microseconds(task: str, n: int = 64, steps: int = 200) -> float:
    """The host time of one ``step()`` (us, median of 5 runs of ``steps``) with the kernels' launches stubbed out."""
    from unittest import mock

    envs = make(task, n)
    actions = torch.zeros((n, 2), device=envs.unwrapped.device)
    envs.step(actions)
    with mock.patch.object(gpu.Launch, "__call__", lambda launch: None):
        times = []
        for _ in range(5):
            start = time.perf_counter()
            for _ in range(steps):
                envs.step(actions)
            times.append((time.perf_counter() - start) / steps)
    envs.close()
    return 1e6 * statistics.median(times)


def cartpole_rate(n: int, steps: int) -> float:
    envs = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    actions = np.random.default_rng(0).integers(0, 2, (steps, n))

    def run():
        for step in range(steps):
            envs.step(actions[step])

    return _median_rate(run, n * steps)


def jax_cartpole():
    """CartPole's equations and termination (Gymnasium's ``CartPoleEnv``: Euler, tau 0.02 s, force 10 N) as a jitted
    JAX function of (states (N, 4), actions (steps, N)), or None where JAX sees no GPU."""
    try:
        import jax
        import jax.numpy as jnp
    except ImportError:
        return None
    if jax.default_backend() != "gpu":
        return None
    gravity, cart, pole, half_length, force, tau = 9.8, 1.0, 0.1, 0.5, 10.0, 0.02
    total, pole_moment = cart + pole, pole * half_length

    def step(state, action):
        x, x_dot, theta, theta_dot = state
        f = jnp.where(action == 1, force, -force)
        cos, sin = jnp.cos(theta), jnp.sin(theta)
        temp = (f + pole_moment * theta_dot**2 * sin) / total
        theta_acc = (gravity * sin - cos * temp) / (half_length * (4.0 / 3.0 - pole * cos**2 / total))
        x_acc = temp - pole_moment * theta_acc * cos / total
        new = jnp.stack([x + tau * x_dot, x_dot + tau * x_acc, theta + tau * theta_dot, theta_dot + tau * theta_acc])
        done = (jnp.abs(new[0]) > 2.4) | (jnp.abs(new[2]) > 12 * 2 * math.pi / 360)
        return jnp.where(done, jnp.zeros(4), new), done

    def rollout(states, actions):
        def body(states, action):
            return jax.vmap(step)(states, action)

        return jax.lax.scan(body, states, actions)

    return jax.jit(rollout), jnp


def jax_rate(function, jnp, n: int, steps: int) -> float:
    states = jnp.zeros((n, 4))
    actions = jnp.asarray(np.random.default_rng(0).integers(0, 2, (steps, n)))
    return _median_rate(lambda: function(states, actions)[0].block_until_ready(), n * steps)


def gpu_name() -> str:
    """The GPU and its driver (``nvidia-smi``), or the simulator."""
    if gpu.SIMULATED:
        return "numba-cuda's simulator on the CPU (no GPU: smoke test, the numbers mean nothing)"
    try:
        line = subprocess.run(
            ["nvidia-smi", "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.splitlines()[0]
        name, driver, memory = (part.strip() for part in line.split(","))
        return f"{name} ({memory}), driver {driver}"
    except (OSError, subprocess.CalledProcessError, IndexError, ValueError):
        return torch.cuda.get_device_name()


def chart(sizes, rows: dict[str, list[float]], path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8), facecolor="white")
    for name, values in rows.items():
        points = [(n, v) for n, v in zip(sizes, values) if v is not None]
        style = "--" if "CartPole" in name else "-"
        ax.loglog(*zip(*points), style, marker="o", markersize=3, label=name)
    ax.set_title(title, fontsize=8)
    ax.set_xlabel("number of disks (environments) N")
    ax.set_ylabel("disk-steps (env steps) per second")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110, facecolor="white")
    plt.close(fig)


def _seconds(value: float | None) -> str:
    """A measured time for the report (s), or that it was not measured."""
    return "not measured" if value is None else f"{value:.3g} s"


class Results:
    """The figures of a run, printed and saved (``gpu.json``) as each is measured, within a time budget."""

    def __init__(self, out, budget: float | None):
        self.path, self.deadline, self.values = out / "gpu.json", time.time() + (budget or math.inf), {}

    def measure(self, key: str, function, *arguments):
        """``function(*arguments)``'s value as ``key`` (None past the budget, or where it failed: the error is
        kept)."""
        if time.time() > self.deadline:
            self.values[key] = "not run (budget)"
            return None
        try:
            value = function(*arguments)
        except Exception as error:  # a row that fails is reported, the others still run
            value = f"failed: {type(error).__name__}: {str(error)[:200]}"
        self.values[key] = value
        print(key, value, flush=True)
        self.path.write_text(json.dumps(self.values, indent=1, default=str))
        return value if not isinstance(value, str) else None


def main() -> None:
    global PHYSICS_STEPS, FUSED_STEPS, ENV_STEPS, REPEATS
    args = arguments(
        __doc__,
        budget={"type": float, "default": None, "help": "seconds for the measurements"},
        sizes={"type": int, "nargs": "+", "default": SIZES, "help": "N (default: %(default)s)"},
        tasks={
            "nargs": "+",
            "choices": list(TASKS),
            "default": list(TASKS),
            "help": "tasks (default: all; --quick: the first)",
        },
    )
    gpu.require_device()
    sizes, cpu_limit, contact_size = tuple(args.sizes), CPU_LIMIT, CONTACT_SIZE
    tasks = {task: TASKS[task] for task in (args.tasks if not args.quick else args.tasks[:1])}
    if args.quick:
        sizes, cpu_limit, contact_size = (64,), 64, 64
        PHYSICS_STEPS, FUSED_STEPS, ENV_STEPS, REPEATS = 2, 1, 2, 1
    results = Results(args.out, args.budget)
    measure = results.measure
    lines = [f"GPU: {gpu_name()}; host: {cpu()}; torch {torch.__version__}, CUDA {torch.version.cuda}.", ""]
    lines += [__doc__.split("\n\n", 2)[2].strip(), ""]
    if gpu.SIMULATED:
        lines += ["Under numba-cuda's simulator: only section 6 means something.", ""]
    host = {task: measure(f"host us a step, {task}", host_microseconds, task) for task in tasks}
    rows: dict[str, list[float | None]] = {"physics only: the model's RK4 step": []}
    rows.update({f"{task}: fused step, {FUSED_STEPS} a launch": [] for task in tasks})
    rows.update({f"{task}: the env's step (torch, GPU)": [] for task in tasks})
    rows.update({f"{task}: the CPU vector env, {os.cpu_count()} cores": [] for task in tasks})
    rows["CartPoleVectorEnv (CPU)"] = []
    jax_cartpole_function = jax_cartpole()
    if jax_cartpole_function is not None:
        rows["CartPole in JAX on the GPU"] = []
    for n in sizes:
        rows["physics only: the model's RK4 step"].append(measure(f"physics N={n}", physics_rate, n, PHYSICS_STEPS))
        for task in tasks:
            env = measure(f"env {task} N={n}", env_rate, task, n, ENV_STEPS, "cuda")
            rows[f"{task}: the env's step (torch, GPU)"].append(env)
            fused = measure(f"fused {task} N={n}", fused_rate, task, n, FUSED_STEPS)
            rows[f"{task}: fused step, {FUSED_STEPS} a launch"].append(fused)
            on_cpu = measure(f"cpu {task} N={n}", env_rate, task, n, ENV_STEPS, None) if n <= cpu_limit else None
            rows[f"{task}: the CPU vector env, {os.cpu_count()} cores"].append(on_cpu)
        on_cpu = measure(f"CartPoleVectorEnv N={n}", cartpole_rate, n, ENV_STEPS) if n <= cpu_limit else None
        rows["CartPoleVectorEnv (CPU)"].append(on_cpu)
        if jax_cartpole_function is not None:
            rows["CartPole in JAX on the GPU"].append(
                measure(f"jax cartpole N={n}", jax_rate, *jax_cartpole_function, n, PHYSICS_STEPS)
            )
    header = ["disk-steps/s", *(f"N = {n:,}" for n in sizes)]
    body = [[name, *("" if v is None else f"{v:.3g}" for v in values)] for name, values in rows.items()]
    lines += ["## Throughput", "", "![throughput against N](gpu.png)", "", table(header, body), ""]
    first = [rows[f"{task}: the env's step (torch, GPU)"][0] for task in tasks]
    lines += [
        f"One step at N = {sizes[0]:,}: "
        + ", ".join(f"{task} {1e6 * sizes[0] / rate:.0f} us" for task, rate in zip(tasks, first) if rate)
        + ".",
        "",
    ]
    chart(sizes, rows, args.out / "gpu.png", f"{gpu_name()}; host: {cpu()}")

    try:  # the sections below report what was measured, even where one of them fails
        biggest = sizes[-1]
        seeding = [
            measure(f"reset(seed=0) s GPU N={biggest}", reset_seconds, biggest, "cuda"),
            measure(f"reset(seed=0) s CPU N={min(biggest, 2**20)}", reset_seconds, min(biggest, 2**20), None),
        ]
        lines += [
            "## Seeding, memory, bandwidth",
            "",
            f"- `reset(seed=0)`: {_seconds(seeding[0])} on the GPU at N = {biggest:,}; {_seconds(seeding[1])} for "
            f"the CPU vector env at N = {min(biggest, 2**20):,} (a fresh env, its kernels compiled at N = 64 first).",
        ]
        peak = peak_bandwidth()
        for task in tasks:
            envs = make(task, 1024)
            envs.step(torch.zeros((1024, 2), device=envs.unwrapped.device))
            moved = step_bytes(envs)
            resources = kernel_resources(envs)
            envs.close()
            memory = measure(f"memory a disk {task}", memory_per_disk, task, min(biggest, 2**20))
            rate = rows[f"{task}: the env's step (torch, GPU)"][-1]
            share = f"{moved * rate / peak:.0%} of {peak / 1e9:.0f} GB/s" if rate and peak else "n/a"
            fits = f"{0.9 * torch.cuda.mem_get_info()[1] / memory:,.0f}" if memory and not gpu.SIMULATED else "n/a"
            lines.append(
                f"- `{task}`: a step moves {moved:.0f} bytes a disk ({share} at N = {biggest:,}); a disk takes "
                f"{memory or 0:.0f} bytes of GPU memory, so about {fits} disks fit in 90% of it; registers and local "
                f"memory (bytes) a thread: "
                + ", ".join(f"{name} {regs}/{local}" for name, (regs, local) in resources.items())
                + "."
            )
            results.values[f"resources {task}"] = resources
        lines.append("")

        contact_rows = []
        for name, contact in BATCH_CONTACTS.items():
            rates = [
                measure(f"driven {name} {where} N={contact_size}", driven_rate, contact_size, device, contact, 10)
                for where, device in (("gpu", "cuda"), ("cpu", None))
            ]
            contact_rows.append((name, rates))
        rolling = contact_rows[0][1]
        body = []
        for name, rates in contact_rows:
            cells = [name]
            for rate, base in zip(rates, rolling):
                cells += (
                    ["", ""]
                    if not rate or not base
                    else [f"{rate[0]:.3g} ({rate[1]:.1%} slid)", f"{base[0] / rate[0]:.2f}x"]
                )
            body.append(cells)
        lines += [
            f"## The Coulomb contact against the rolling one (N = {contact_size:,})",
            "",
            table(
                ["batch", "GPU disk-steps/s", "GPU time vs rolling", "CPU disk-steps/s", "CPU time vs rolling"], body
            ),
            "",
        ]

        body = []
        for task in tasks:
            for contact in ({}, {"contact": "coulomb", "friction_coefficient": 0.2}):
                for mode in ("NextStep", "SameStep", "Disabled"):
                    counts = measure(
                        f"crossings {task} {contact.get('contact', 'rolling')} {mode}",
                        crossings,
                        task,
                        mode,
                        contact,
                    )
                    if counts:
                        reads = counts.get("reads", 0)
                        body.append(
                            [
                                task,
                                contact.get("contact", "rolling"),
                                mode,
                                counts.get("launches", 0),
                                reads,
                                counts.get("copies", 0),
                                16 * reads,
                            ]
                        )
        lines += [
            "## What crosses in a step",
            "",
            "Counted at the package's entry points (`gpu.Launch`, the status read, `gpu.to_device`, `gpu.to_host`, "
            "and `Tensor.__bool__`, `item`, `cpu`, `tolist`) over 4 steps after a first; torch's own launches (the "
            "copy of the actions, the fresh outputs' copy, the status word's copy) are not counted.",
            "",
            table(
                ["task", "contact", "autoreset", "kernel launches", "reads of the device", "copies", "bytes crossing"],
                body,
            ),
            "",
            "Host time of one `step()` at N = 64 with the launches stubbed out: "
            + ", ".join(f"{task} {value:.0f} us" for task, value in host.items() if value)
            + ".",
        ]
    except Exception as error:  # written into the results, the run's other figures kept
        lines += ["", f"The report stopped: {type(error).__name__}: {error}"]
    write_markdown(
        "gpu",
        "On a GPU",
        "python benchmarks/bench_gpu.py" + (" --quick" if args.quick else ""),
        lines,
        args.out,
    )


if __name__ == "__main__":
    main()
