"""Meta-World task names, benchmark sets and the task-definition registry."""

from __future__ import annotations

import importlib
import pkgutil

from . import tasks as _tasks_pkg
from .task import MetaWorldTask

# MTBench's task index (``franka_base.py: TASK_IDX_TO_NAME``); the order of MT50.
ALL_TASK_NAMES: tuple[str, ...] = (
    "assembly", "basketball", "bin_picking", "box_close", "button_press_topdown", "button_press_topdown_wall",
    "button_press", "button_press_wall", "coffee_button", "coffee_pull", "coffee_push", "dial_turn",
    "disassemble", "door_close", "door_lock", "door_unlock", "door_open", "drawer_close", "drawer_open",
    "faucet_close", "faucet_open", "hammer", "hand_insert", "handle_press_side", "handle_press",
    "handle_pull_side", "handle_pull", "lever_pull", "peg_insert_side", "peg_unplug_side", "pick_out_of_hole",
    "pick_place", "pick_place_wall", "plate_slide_back_side", "plate_slide_back", "plate_slide_side",
    "plate_slide", "push_back", "push", "push_wall", "reach", "reach_wall", "shelf_place", "soccer",
    "stick_pull", "stick_push", "sweep_into_goal", "sweep", "window_close", "window_open",
)

# The standard MT10 (MTBench task ids [4,16,17,18,28,31,38,40,48,49]), in MTBench's sorted-id order.
MT10: tuple[str, ...] = (
    "button_press_topdown", "door_open", "drawer_close", "drawer_open", "peg_insert_side", "pick_place", "push",
    "reach", "window_close", "window_open",
)
MT50: tuple[str, ...] = ALL_TASK_NAMES



def _discover_tasks() -> dict[str, type[MetaWorldTask]]:
    """Collect every ``MetaWorldTask`` subclass defined in the modules of ``mtbench.envs.metaworld.tasks``."""
    found: dict[str, type[MetaWorldTask]] = {}
    for info in pkgutil.iter_modules(_tasks_pkg.__path__):
        module = importlib.import_module(f"{_tasks_pkg.__name__}.{info.name}")
        for obj in vars(module).values():
            if isinstance(obj, type) and issubclass(obj, MetaWorldTask) and obj.__module__ == module.__name__:
                if obj.name in found:
                    raise RuntimeError(f"task {obj.name!r} defined twice ({found[obj.name]} and {obj})")
                found[obj.name] = obj
    return found


TASKS: dict[str, type[MetaWorldTask]] = _discover_tasks()


def task_class(name: str) -> type[MetaWorldTask]:
    """The task definition for ``name``; raises with the valid choices otherwise."""
    if name in TASKS:
        return TASKS[name]
    if name in ALL_TASK_NAMES:
        raise NotImplementedError(
            f"Meta-World task {name!r} is not implemented in this version of mtbench; implemented: {sorted(TASKS)}"
        )
    raise ValueError(f"unknown Meta-World task {name!r}; valid choices: {sorted(TASKS)}")
