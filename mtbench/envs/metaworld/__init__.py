"""Meta-World manipulation tasks on a Franka Panda (MuJoCo Warp)."""

from .env import MetaWorldEnv
from .registry import ALL_TASK_NAMES, MT10, MT50, NUM_METAWORLD_TASKS, TASKS, benchmark_tasks, task_class
from .task import REWARD_VERSIONS

__all__ = ["ALL_TASK_NAMES", "MT10", "MT50", "MetaWorldEnv", "NUM_METAWORLD_TASKS", "REWARD_VERSIONS", "TASKS",
           "benchmark_tasks", "task_class"]
