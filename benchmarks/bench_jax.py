"""The disk in JAX: env steps per second of a jit-compiled ``lax.scan`` rollout, beside gymnax's CartPole, the RK4
step alone and the numba vector env, in float64 and float32; XLA's compile times.

``python benchmarks/bench_jax.py [--quick] [--sizes N ...] [--out DIR]`` writes ``jax.md`` and ``jax_throughput.png``
to DIR (default ``benchmarks/results``) where JAX runs on the CPU, ``jax_gpu.md`` and ``jax_gpu_throughput.png`` where
it runs on a GPU (the device named in the file). Needs the ``[jax]`` extra.

1. Throughput: ``steps`` steps of N disks in one compiled ``lax.scan`` whose body draws the N random actions from a
   key and steps the vmapped env (gymnax's ``step``, autoreset included), for the tasks ``upright`` and ``goto``,
   gymnax's ``CartPole-v1`` (its actions drawn alike), and ``physics``: the RK4 step of the full model alone (the
   generated kernel read as JAX, random torques), in float64 (``jax_enable_x64``) and float32; and the numba vector
   env of ``upright`` (``gym.make_vec``, float64, on numba's threads from 2,048 disks where they measure faster,
   actions drawn beforehand), timed in the same run.
   Env steps per second are N * steps over the wall time of a call (median of repeats, after a first call that
   compiles).
2. Compile time: XLA's ``lower`` + ``compile`` of the rollout of ``upright`` at N = 1024 (float64 and float32).
"""

from __future__ import annotations

import statistics
import time

# rolling_disk_env.jax first: it sets XLA's CPU flags, which importing gymnax (it starts JAX's backend) would fix.
from rolling_disk_env.jax import make, traced  # isort: skip

import gymnasium as gym
import gymnax
import jax
import jax.numpy as jnp
import numpy as np
from _common import arguments, table, write_markdown

import rolling_disk_env as rd
from rolling_disk_env._generated import kernels

jax.config.update("jax_enable_x64", True)
SIZES = (1, 64, 1024, 16384)
NUMBA_LIMIT = 65536  # the numba vector env's row stops here: seconds a call beyond on a few cores
STEPS = 100


def env_rollout(env, params, count: int, steps: int):
    """A compiled function of a key: ``steps`` steps of ``count`` disks under random actions drawn inside."""
    space = env.action_space(params)

    def run(key):
        keys = jax.random.split(key, count)
        _, states = jax.vmap(env.reset, in_axes=(0, None))(keys, params)

        def body(carry, _):
            states, key = carry
            key, draw, step = jax.random.split(key, 3)
            actions = jax.vmap(space.sample)(jax.random.split(draw, count))
            _, states, rewards, *_ = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                jax.random.split(step, count), states, actions, params
            )
            return (states, key), rewards.sum()

        return jax.lax.scan(body, (states, key), None, steps)[1].sum()

    return jax.jit(run)


def physics_rollout(count: int, steps: int):
    """The RK4 step of the full model alone, ``count`` disks, random torques drawn inside."""
    step = jax.vmap(traced(kernels.state_rk4_step), in_axes=(0, None, 0, 0, None, None, None))
    dtype = jnp.result_type(float)

    def run(key):
        x = jnp.zeros((8, count), dtype).at[5].set(2.0)

        def body(carry, _):
            x, key = carry
            key, draw = jax.random.split(key)
            torques = jax.random.uniform(draw, (2, count), dtype, -1.0, 1.0)
            x = jnp.stack(step(tuple(x), 0.02, torques[0], torques[1], 5.0, 9.81, 1.0))
            return (x, key), None

        return jax.lax.scan(body, (x, key), None, steps)[0][0].sum()

    return jax.jit(run)


def rate(function, count: int, steps: int, repeats: int) -> float:
    """Env steps per second of a compiled rollout (median of ``repeats`` calls after the first)."""
    jax.block_until_ready(function(jax.random.PRNGKey(0)))
    times = []
    for repeat in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(function(jax.random.PRNGKey(repeat + 1)))
        times.append(time.perf_counter() - start)
    return count * steps / statistics.median(times)


def numba_rate(count: int, steps: int, repeats: int) -> float:
    envs = gym.make_vec(rd.TASK_IDS["upright"], num_envs=count, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, count, 2)).astype(np.float32)
    for action in actions[:5]:
        envs.step(action)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for action in actions:
            envs.step(action)
        times.append(time.perf_counter() - start)
    envs.close()
    return count * steps / statistics.median(times)


def rollouts(count: int, steps: int) -> dict:
    """The compiled rollouts of the current precision."""
    cartpole, cartpole_params = gymnax.make("CartPole-v1")
    functions = {name: env_rollout(*make(name), count, steps) for name in ("upright", "goto")}
    functions["CartPole-v1 (gymnax)"] = env_rollout(cartpole, cartpole_params, count, steps)
    functions["physics (RK4 step)"] = physics_rollout(count, steps)
    return functions


def compile_seconds(count: int, steps: int) -> float:
    env, params = make("upright")
    function = env_rollout(env, params, count, steps)
    start = time.perf_counter()
    function.lower(jax.random.PRNGKey(0)).compile()
    return time.perf_counter() - start


def main() -> None:
    args = arguments(__doc__, sizes={"type": int, "nargs": "+", "default": SIZES, "help": "N (default: %(default)s)"})
    sizes, repeats = ((1, 64), 2) if args.quick else (tuple(args.sizes), 3)
    device = jax.devices()[0]
    stem = "jax" if device.platform == "cpu" else f"jax_{device.platform}"
    results = {}  # (name, precision) -> {N: rate}
    for count in sizes:
        for precision, x64 in (("float64", True), ("float32", False)):
            with jax.enable_x64(x64):
                for name, function in rollouts(count, STEPS).items():
                    results.setdefault((name, precision), {})[count] = rate(function, count, STEPS, repeats)
        if count <= NUMBA_LIMIT:
            results.setdefault(("numba vector env, upright", "float64"), {})[count] = numba_rate(count, STEPS, repeats)
        measured = {key: f"{value[count] / 1e6:.3f}M" for key, value in results.items() if count in value}
        print(count, measured, flush=True)
    compiles = []
    for precision, x64 in (("float64", True), ("float32", False)):
        with jax.enable_x64(x64):
            compiles.append([precision, f"{compile_seconds(1024, STEPS):.2f}"])

    header = ["env", "precision", *(f"N = {count}" for count in sizes)]
    rows = [
        [name, precision, *(f"{values[count] / 1e6:.3f}M" if count in values else "" for count in sizes)]
        for (name, precision), values in results.items()
    ]
    sections = [
        "## Env steps per second",
        "",
        f"{STEPS} steps of N disks in one compiled `lax.scan` (random actions drawn inside; autoreset), median of "
        f"{repeats} calls; the numba vector env of `upright` (numba's threads from 2,048 disks where they measure "
        "faster, actions drawn beforehand) in the same run.",
        "",
        table(header, rows),
        "",
        f"![throughput]({stem}_throughput.png)",
        "",
        "## XLA compile time",
        "",
        f"`lower` + `compile` of the rollout of `upright`, N = 1024, {STEPS} steps (s):",
        "",
        table(["precision", "seconds"], compiles),
    ]
    command = "python benchmarks/bench_jax.py" + (" --quick" if args.quick else f" --sizes {' '.join(map(str, sizes))}")
    title = f"The disk in JAX: rollout throughput on {device.device_kind} (JAX {jax.__version__})"
    write_markdown(stem, title, command, sections, args.out)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4.5))
    for (name, precision), values in results.items():
        style = "-" if precision == "float64" else "--"
        axes.loglog(list(values), list(values.values()), style, marker="o", label=f"{name}, {precision}")
    axes.set_xlabel("disks N")
    axes.set_ylabel("env steps per second")
    axes.set_title(f"Compiled lax.scan rollouts in JAX on {device.device_kind}")
    axes.legend(fontsize=7)
    axes.grid(True, which="both", alpha=0.3)
    figure.tight_layout()
    figure.savefig(args.out / f"{stem}_throughput.png", dpi=120)


if __name__ == "__main__":
    main()
