"""Meta-World manipulation tasks on a Franka Panda (MuJoCo Warp)."""

from .env import MetaWorldEnv
from .registry import ALL_TASK_NAMES, MT10, MT50, TASKS, task_class

__all__ = ["ALL_TASK_NAMES", "MT10", "MT50", "MetaWorldEnv", "TASKS", "task_class"]
