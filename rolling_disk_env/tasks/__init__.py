"""The tasks of RollingDisk-v0, one module each.

The recipe for a new task ``"name"``:

1. Write ``rolling_disk_env/tasks/name.py`` (``upright.py`` is the smallest example) with
    * a :class:`Task` subclass: its options (checked in ``__init__``), observation names and bounds, named reward terms
      with default weights, goal names, the settings its formulas read, initial-state ranges (and goal ranges), fall
      lean and success rule, and a class docstring documenting them in the style of the env's manual;
    * its formulas as module-level kernels (``@kernel`` from :mod:`rolling_disk_env.jit`): ``start``, ``observe``,
      ``reward_terms``, ``termination`` and, for the success rule ``TRACK``, ``tracking_error``. They are plain Python
      on floats and arrays, with the signatures documented in :mod:`rolling_disk_env.tasks.base`.
2. Add the class to :data:`TASKS` below, and its id to ``TASK_SPECS`` in ``rolling_disk_env/__init__.py``.
3. Run ``python -m rolling_disk_env.codegen``: it writes ``_generated/name.py``, the fused step of the task with each
   integrator, which both envs run (``tests/test_codegen.py`` fails until it is current).
4. Document the task in the env's class docstring (its observation table), the README's table of tasks and a page of
   the manual, ``docs/tasks/name.md`` (in ``mkdocs.yml``'s nav), with its classical agent's episode from
   ``python -m agents.evaluate --task name --agent baseline --out docs/tasks/name``; the tests parametrized over
   :data:`TASKS` (checkers, single against vector env, autoreset modes) then cover it.
"""

from rolling_disk_env.tasks.base import Task
from rolling_disk_env.tasks.circle import CircleTask
from rolling_disk_env.tasks.eight import EightTask
from rolling_disk_env.tasks.goto import GotoTask
from rolling_disk_env.tasks.ice import IceTask
from rolling_disk_env.tasks.recovery import RecoveryTask
from rolling_disk_env.tasks.recovery_sparse import RecoverySparseTask
from rolling_disk_env.tasks.upright import UprightTask
from rolling_disk_env.tasks.waypoints import WaypointsTask

TASKS: dict[str, type[Task]] = {
    task.name: task
    for task in (UprightTask, CircleTask, GotoTask, WaypointsTask, EightTask, RecoveryTask, RecoverySparseTask, IceTask)
}

__all__ = [
    "TASKS",
    "CircleTask",
    "EightTask",
    "GotoTask",
    "IceTask",
    "RecoveryTask",
    "Task",
    "UprightTask",
    "WaypointsTask",
]
