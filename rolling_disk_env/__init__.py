"""rolling-disk-env: a disk rolling without slipping on a plane (L. Jaulin's SymPy model) as a Gymnasium env.

Importing the package registers ``"RollingDisk-v0"`` and one id per task (:data:`TASK_IDS`) with Gymnasium
(idempotently, so that ``SubprocVecEnv`` children, which import it again, find the ids), and ``"RollingDiskJax-v0"``
(:data:`JAX_ID`, the tasks in JAX, with the ``[jax]`` extra).

It imports neither SymPy nor numba nor torch: the envs (and with them the compiled engine) load on first use, through
``gymnasium.make`` or the attributes ``RollingDiskEnv``, ``RollingDiskVectorEnv`` and ``Termination``, and the
Stable-Baselines3 adapter (with SB3 and torch, from the ``[train]`` extra) on first use of the attribute ``sb3``.
"""

import importlib

from gymnasium.envs.registration import register, registry

from rolling_disk_env.dynamics import (
    LEAN_LIMIT,
    LEAN_MARGIN,
    SLIDING_STATE_NAMES,
    DiskParams,
    OutOfDomainError,
    contact_force,
    energy,
    friction_force,
    lean_derivative,
    lean_jacobians,
    lean_state,
    normal_force,
    required_friction,
    sliding_derivative,
    sliding_energy,
    sliding_normal_force,
    sliding_state,
    slip_velocity,
    state_derivative,
    steady_motion,
    steady_motion_eigenvalues,
)
from rolling_disk_env.integrators import CONTACTS, METHODS, RollingContactError, simulate

ENV_ID = "RollingDisk-v0"
"""The general id: task ``"upright"`` by default, every keyword argument accepted (``task=`` included)."""
MAX_EPISODE_STEPS = 500
"""Steps of 0.02 s in an episode (10 s): ``RollingDisk-v0``'s limit, and most tasks' ids'."""
TASK_SPECS = (
    ("upright", "RollingDiskUpright-v0", 450.0, MAX_EPISODE_STEPS),
    ("circle", "RollingDiskCircle-v0", 450.0, MAX_EPISODE_STEPS),
    ("goto", "RollingDiskGoto-v0", 150.0, MAX_EPISODE_STEPS),
    ("waypoints", "RollingDiskWaypoints-v0", 250.0, 1000),
    ("eight", "RollingDiskEight-v0", 1000.0, 1250),
    ("recovery", "RollingDiskRecovery-v0", 80.0, MAX_EPISODE_STEPS),
    ("recovery_sparse", "RollingDiskRecoverySparse-v0", 0.9, MAX_EPISODE_STEPS),
    ("ice", "RollingDiskIce-v0", 150.0, MAX_EPISODE_STEPS),
)
"""One id per task, with the task fixed: ``(task, id, reward_threshold, max_episode_steps)``. A new task's id is one
more line. ``RollingDisk-v0`` truncates every task at :data:`MAX_EPISODE_STEPS`, unless ``gymnasium.make`` is given
``max_episode_steps`` (the longer tasks' ids take theirs)."""
TASK_IDS = {task: env_id for task, env_id, *_ in TASK_SPECS}
"""The id of each task (the ids rl-baselines3-zoo's hyperparameter files are keyed by)."""
TASK_MAX_STEPS = {task: steps for task, _, _, steps in TASK_SPECS}
"""The episode length of each task's id, in control periods."""
JAX_ID = "RollingDiskJax-v0"
"""The tasks in JAX through Gymnasium's functional API (``task=`` chooses; needs the ``[jax]`` extra):
:mod:`rolling_disk_env.jax.functional`."""


def _register() -> None:
    """Registers the ids that are missing: idempotent, as SubprocVecEnv children import the package again."""
    specs = [
        (ENV_ID, {}, 450.0, MAX_EPISODE_STEPS),
        *((env_id, {"task": task}, threshold, steps) for task, env_id, threshold, steps in TASK_SPECS),
    ]
    for env_id, kwargs, threshold, steps in specs:
        if env_id not in registry:
            register(
                id=env_id,
                entry_point="rolling_disk_env.envs:RollingDiskEnv",
                vector_entry_point="rolling_disk_env.envs:vector_env",
                max_episode_steps=steps,
                reward_threshold=threshold,
                kwargs=kwargs,
            )
    if JAX_ID not in registry:
        register(
            id=JAX_ID,
            entry_point="rolling_disk_env.jax.functional:RollingDiskJaxEnv",
            vector_entry_point="rolling_disk_env.jax.functional:RollingDiskJaxVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
            disable_env_checker=True,  # its observations are JAX arrays, as Gymnasium's phys2d ids' (which do so)
        )


_register()


def __getattr__(name: str):
    """The envs and ``info["termination"]``'s codes, imported on first use (with numba, which compiles the engine's
    kernels), and the submodule ``sb3`` (it imports Stable-Baselines3 and torch)."""
    if name in ("RollingDiskEnv", "RollingDiskVectorEnv", "Termination"):
        from rolling_disk_env import envs

        return getattr(envs, name)
    if name == "sb3":
        return importlib.import_module(f"{__name__}.sb3")  # not `from . import sb3`: that asks this function again
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "CONTACTS",
    "ENV_ID",
    "LEAN_LIMIT",
    "LEAN_MARGIN",
    "MAX_EPISODE_STEPS",
    "METHODS",
    "SLIDING_STATE_NAMES",
    "TASK_IDS",
    "TASK_MAX_STEPS",
    "TASK_SPECS",
    "DiskParams",
    "OutOfDomainError",
    "RollingContactError",
    "RollingDiskEnv",
    "RollingDiskVectorEnv",
    "Termination",
    "contact_force",
    "energy",
    "friction_force",
    "lean_derivative",
    "lean_jacobians",
    "lean_state",
    "normal_force",
    "required_friction",
    "simulate",
    "sliding_derivative",
    "sliding_energy",
    "sliding_normal_force",
    "sliding_state",
    "slip_velocity",
    "state_derivative",
    "steady_motion",
    "steady_motion_eigenvalues",
]
