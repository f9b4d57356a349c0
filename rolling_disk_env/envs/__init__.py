"""The Gymnasium environments: one disk (RollingDiskEnv) and N disks in one batch (RollingDiskVectorEnv)."""

from rolling_disk_env.envs.config import Termination
from rolling_disk_env.envs.factory import vector_env
from rolling_disk_env.envs.rolling_disk import RollingDiskEnv
from rolling_disk_env.envs.vector import RollingDiskVectorEnv

__all__ = ["RollingDiskEnv", "RollingDiskVectorEnv", "Termination", "vector_env"]
