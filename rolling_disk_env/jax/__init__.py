"""The disk in JAX: each task of RollingDisk-v0 as a gymnax environment, from the same kernels as the numba engine.

``pip install -e ".[jax]"`` (jax with its CPU jaxlib, gymnax, rejax). Importing this subpackage imports JAX; the
package itself never does. See :mod:`rolling_disk_env.jax.env` for what is supported and the manual's page "In JAX".
"""

from rolling_disk_env.jax.env import EnvParams, EnvState, RollingDiskJax
from rolling_disk_env.jax.reading import traced


def make(task: str = "upright", **kwargs) -> tuple[RollingDiskJax, EnvParams]:
    """``(env, params)`` of a task, as ``gymnax.make`` returns them; ``kwargs`` are the Gymnasium env's."""
    env = RollingDiskJax(task, **kwargs)
    return env, env.default_params


__all__ = ["EnvParams", "EnvState", "RollingDiskJax", "make", "traced"]
