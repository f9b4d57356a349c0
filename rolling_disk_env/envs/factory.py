"""The ids' ``vector_entry_point``: the numpy vector env, or the torch one on a device.

Apart from both envs, so that neither imports the other: the torch env extends the numpy one, and this factory
imports torch (an optional dependency) only where a device is asked for.
"""

from __future__ import annotations

from rolling_disk_env.envs.vector import RollingDiskVectorEnv


def vector_env(num_envs: int = 1, device=None, **kwargs) -> RollingDiskVectorEnv:
    """:class:`~rolling_disk_env.envs.RollingDiskVectorEnv` (numpy), or with ``device`` ("cpu" or "cuda")
    :class:`~rolling_disk_env.envs.torch_vector.RollingDiskTorchVectorEnv` (torch tensors on that device)."""
    if device is None:
        return RollingDiskVectorEnv(num_envs, **kwargs)
    try:
        from rolling_disk_env.envs.torch_vector import RollingDiskTorchVectorEnv
    except ModuleNotFoundError as error:
        raise ImportError(f"device={device!r} hands out torch tensors and needs torch: pip install torch") from error

    return RollingDiskTorchVectorEnv(num_envs, device=device, **kwargs)
