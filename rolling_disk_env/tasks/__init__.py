"""The tasks of RollingDisk-v0. A new task is one module with a :class:`Task` subclass plus one line here."""

from rolling_disk_env.tasks.base import Task
from rolling_disk_env.tasks.circle import CircleTask
from rolling_disk_env.tasks.upright import UprightTask

TASKS: dict[str, type[Task]] = {task.name: task for task in (UprightTask, CircleTask)}

__all__ = ["TASKS", "CircleTask", "Task", "UprightTask"]
