"""The disk in JAX: each task of RollingDisk-v0 as a gymnax environment, from the same kernels as the numba engine.

``pip install -e ".[jax]"`` (jax with its CPU jaxlib, gymnax, rejax). Importing this subpackage imports JAX; the
package itself never does. See :mod:`rolling_disk_env.jax.env` for what is supported and the manual's page "In JAX".

Importing it also adds :data:`CPU_FLAGS` to ``XLA_FLAGS`` (unless ``XLA_FLAGS`` names that option already): XLA's
newer CPU fusion emitters compile the model's steps into code 65 times slower than its classic ones (the RK4 step of
4096 disks: 21 us against 0.33 us a disk, ``benchmarks/bench_jax.py``'s machine). XLA reads the flag when JAX makes
its CPU backend, at the first computation: import this subpackage before that, or set the flag yourself. jaxlib 0.11
removed the option, and XLA stops the process at a flag it does not know: from jaxlib 0.11 on nothing is set (seen
on an H100 machine with jax 0.11.2; whether its CPU code has the slowdown is not measured, 0.11 was not on the
registry of the machine that measured it).
"""

import logging
import os
import sys
from importlib import metadata

CPU_FLAGS = "--xla_cpu_use_fusion_emitters=false"
"""The XLA option this subpackage sets for the CPU (see the module docstring)."""


def _xla_knows_cpu_flags() -> bool:
    """Whether the installed jaxlib's XLA has :data:`CPU_FLAGS`'s option (releases before 0.11), read without
    importing JAX."""
    try:
        major, minor = (int(part) for part in metadata.version("jaxlib").split(".")[:2])
    except (metadata.PackageNotFoundError, ValueError) as error:
        logging.getLogger(__name__).debug("jaxlib's version not read (%s): %s not set", error, CPU_FLAGS)
        return False
    return (major, minor) < (0, 11)


if _xla_knows_cpu_flags() and CPU_FLAGS.partition("=")[0] not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {CPU_FLAGS}".strip()
    started = sys.modules.get("jax._src.xla_bridge")  # JAX's own module: no public test of a started backend
    if started is not None and started.backends_are_initialized():
        logging.getLogger(__name__).warning(
            "rolling_disk_env.jax: JAX's backend has started (importing gymnax starts it), so XLA ignores %s and "
            "compiles the disk's steps into slow CPU code; import rolling_disk_env.jax first, or set XLA_FLAGS",
            CPU_FLAGS,
        )

# The modules that import JAX come after the flag is set.

from rolling_disk_env.jax.env import EnvParams, EnvState, RollingDiskJax  # noqa: E402
from rolling_disk_env.jax.reading import traced  # noqa: E402


def make(task: str = "upright", **kwargs) -> tuple[RollingDiskJax, EnvParams]:
    """``(env, params)`` of a task, as ``gymnax.make`` returns them; ``kwargs`` are the Gymnasium env's."""
    env = RollingDiskJax(task, **kwargs)
    return env, env.default_params


__all__ = ["CPU_FLAGS", "EnvParams", "EnvState", "RollingDiskJax", "make", "traced"]
