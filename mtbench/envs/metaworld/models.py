"""Compile each task's MuJoCo model once per process (shared by every env that uses the task)."""

from __future__ import annotations

from functools import lru_cache

import mujoco

from .registry import task_class
from .scene import build_scene
from .task import MetaWorldTask


@lru_cache(maxsize=None)
def compiled_task(name: str, robot_collision: str = "primitive") -> tuple[type[MetaWorldTask], mujoco.MjModel]:
    """``(task class, compiled MjModel)`` for the task ``name`` with the given hand/finger collision geometry."""
    cls = task_class(name)
    return cls, build_scene(cls.scene, edit_spec=cls.edit_spec, robot_collision=robot_collision)
