"""GPU throughput: disk-steps per second of the CUDA kernels, physics only and through the env's step, beside the CPU
vector env on all the host's cores, Gymnasium's ``CartPoleVectorEnv`` and a JAX CartPole on the same GPU, in one run.

``python benchmarks/bench_gpu.py [--quick] [--out DIR]`` writes ``gpu.md`` and ``gpu.png`` to DIR (default
``benchmarks/results``). Needs the ``[gpu]`` extra and a CUDA GPU (under numba-cuda's simulator,
``NUMBA_ENABLE_CUDASIM=1``, ``--quick`` runs it as a smoke test on the CPU: its numbers mean nothing).

1. Physics only: the generated model's RK4 step (``_generated/kernels.py``, ``state_rk4_step_from``: the CPU's code,
   compiled by numba-cuda) for :data:`PHYSICS_STEPS` steps of 0.02 s a launch, a GPU thread a disk, its state in
   registers; and each task's fused step (``_generated/<task>.py``'s ``step_rk4_share``: torques, RK4, contact,
   termination, rewards, observation) :data:`FUSED_STEPS` times a launch.
2. The env's step: ``gym.make_vec(..., device="cuda")``, random actions drawn on the GPU beforehand, next-step
   autoreset, torch tensors out, timed over whole steps with ``torch.cuda.synchronize()``.
3. Anchors, timed in the same run: the numpy vector env on the host's cores, ``CartPoleVectorEnv``, and CartPole's
   equations (Gymnasium's, Euler) in JAX, ``vmap`` over the batch and ``lax.scan`` over :data:`PHYSICS_STEPS` steps,
   jitted for the GPU, where JAX sees one.

Each figure is the median of :data:`REPEATS` timed runs after a warm-up run (which compiles).
"""

from __future__ import annotations

import math
import os
import statistics
import subprocess
import time

import gymnasium as gym
import numpy as np
import torch
from _common import arguments, cpu, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env import gpu
from rolling_disk_env._generated import circle, goto, kernels, upright
from rolling_disk_env.envs.config import EnvConfig

cuda = gpu.cuda
"""numba-cuda's ``numba.cuda`` (:mod:`rolling_disk_env.gpu` checks that it is numba-cuda's)."""
SIZES = tuple(2**p for p in range(10, 23, 2))
"""N: 1,024 to 4,194,304 disks."""
CPU_LIMIT = 2**16
"""The largest N of the CPU anchors (their step takes seconds beyond)."""
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
        actions, batch, setup, out, resets = arguments
        k = cuda.grid(1)
        if k < batch[0].shape[1]:
            for _ in range(count):
                share(np.int64(k), actions, batch, setup, out, resets)

    return cuda.jit(fused)


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
    batch = gpu.DeviceBatch(EnvConfig.from_kwargs(task=task), n, 500)
    words = np.random.default_rng(0).integers(0, 2**64, size=(n, 4), dtype=np.uint64, endpoint=False)
    words[:, 3] |= np.uint64(1)  # any PCG64 state with an odd increment: each disk its own episode
    batch.seed(list(range(n)), words)
    batch.reset(torch.ones(n, dtype=torch.bool), batch.outputs(), batch.rngs)
    batch.step(torch.zeros((n, 2), device=batch.device), batch.outputs())  # leaves zero actions and no reset
    kernel, arguments = _fused(TASKS[task]), batch.step_arguments()
    return _median_rate(lambda: gpu.launch(kernel, n, arguments, steps), n * steps)


def env_rate(task: str, n: int, steps: int, device: str | None) -> float:
    """The env's step: on the GPU (``device="cuda"``) or the numpy vector env (None), random actions."""
    extra = {} if device is None else {"device": device}
    envs = gym.make_vec(rd.ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", task=task, **extra)
    envs.reset(seed=0)
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


def main() -> None:
    global PHYSICS_STEPS, FUSED_STEPS, ENV_STEPS, REPEATS
    args = arguments(__doc__)
    gpu.require_device()
    sizes, cpu_limit = SIZES, CPU_LIMIT
    if args.quick:
        sizes, cpu_limit = (64,), 64
        PHYSICS_STEPS, FUSED_STEPS, ENV_STEPS, REPEATS = 2, 1, 2, 1
    rows: dict[str, list[float | None]] = {"physics only: the model's RK4 step": []}
    rows.update({f"{task}: fused step, {FUSED_STEPS} a launch": [] for task in TASKS})
    rows.update({f"{task}: the env's step (torch, GPU)": [] for task in TASKS})
    rows.update({f"{task}: the CPU vector env, {os.cpu_count()} cores": [] for task in TASKS})
    rows["CartPoleVectorEnv (CPU)"] = []
    jax_cartpole_function = jax_cartpole()
    if jax_cartpole_function is not None:
        rows["CartPole in JAX on the GPU"] = []
    for n in sizes:
        print(f"N = {n}", flush=True)
        rows["physics only: the model's RK4 step"].append(physics_rate(n, PHYSICS_STEPS))
        for task in TASKS:
            rows[f"{task}: fused step, {FUSED_STEPS} a launch"].append(fused_rate(task, n, FUSED_STEPS))
            rows[f"{task}: the env's step (torch, GPU)"].append(env_rate(task, n, ENV_STEPS, "cuda"))
            on_cpu = env_rate(task, n, ENV_STEPS, None) if n <= cpu_limit else None
            rows[f"{task}: the CPU vector env, {os.cpu_count()} cores"].append(on_cpu)
        rows["CartPoleVectorEnv (CPU)"].append(cartpole_rate(n, ENV_STEPS) if n <= cpu_limit else None)
        if jax_cartpole_function is not None:
            rows["CartPole in JAX on the GPU"].append(jax_rate(*jax_cartpole_function, n, PHYSICS_STEPS))
    device = gpu_name()
    chart(sizes, rows, args.out / "gpu.png", f"{device}; host: {cpu()}")
    header = ["disk-steps/s", *(f"N = {n:,}" for n in sizes)]
    body = [[name, *("" if v is None else f"{v:.2g}" for v in values)] for name, values in rows.items()]
    write_markdown(
        "gpu",
        "On a GPU",
        "python benchmarks/bench_gpu.py" + (" --quick" if args.quick else ""),
        [
            f"GPU: {device}; torch {torch.__version__}, CUDA {torch.version.cuda}.",
            "",
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            "![throughput against N](gpu.png)",
            "",
            table(header, body),
        ],
        args.out,
    )


if __name__ == "__main__":
    main()
