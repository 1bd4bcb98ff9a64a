"""The Meta-World task registry, derived from the task files, and the benchmark sets.

Every module of ``mtbench.envs.metaworld.tasks`` whose name does not start with ``_`` defines one
:class:`~.task.MetaWorldTask` subclass; the task list is what those files define, ordered by their MTBench task id
(``mtbench_id``, MTBench's ``TASK_IDX_TO_NAME``), which is also the order of the one-hot slots.
"""

from __future__ import annotations

import importlib
import pkgutil

from . import tasks as _tasks_pkg
from .task import MetaWorldTask

NUM_METAWORLD_TASKS = 50  # MTBench's Meta-World task ids 0..49


def _discover_tasks() -> dict[str, type[MetaWorldTask]]:
    """Collect the ``MetaWorldTask`` subclass defined in each public module of ``mtbench.envs.metaworld.tasks``."""
    found: dict[str, type[MetaWorldTask]] = {}
    ids: dict[int, str] = {}
    for info in pkgutil.iter_modules(_tasks_pkg.__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{_tasks_pkg.__name__}.{info.name}")
        defined = [obj for obj in vars(module).values()
                   if isinstance(obj, type) and issubclass(obj, MetaWorldTask) and obj.__module__ == module.__name__
                   and "name" in vars(obj)]
        if len(defined) != 1:
            raise RuntimeError(f"task module {module.__name__} must define exactly one task class, found {defined}")
        cls = defined[0]
        if cls.name != info.name:
            raise RuntimeError(f"task class {cls.__qualname__} is named {cls.name!r} but lives in {info.name}.py")
        for attr in ("mtbench_id", "description", "scene", "reset_low", "reset_high"):
            if not hasattr(cls, attr):
                raise RuntimeError(f"task {cls.name!r} does not set {attr}")
        if not 0 <= cls.mtbench_id < NUM_METAWORLD_TASKS or cls.mtbench_id in ids:
            raise RuntimeError(f"task {cls.name!r}: mtbench_id {cls.mtbench_id} is out of range or already used by "
                               f"{ids.get(cls.mtbench_id)!r}")
        ids[cls.mtbench_id] = cls.name
        found[cls.name] = cls
    return dict(sorted(found.items(), key=lambda item: item[1].mtbench_id))


TASKS: dict[str, type[MetaWorldTask]] = _discover_tasks()
# every implemented task, in MTBench's task-id order
ALL_TASK_NAMES: tuple[str, ...] = tuple(TASKS)

# The standard MT10 (MTBench task ids [4,16,17,18,28,31,38,40,48,49]); benchmark sets list names, the registry
# gives their order (task id).
MT10: tuple[str, ...] = (
    "button_press_topdown", "door_open", "drawer_close", "drawer_open", "peg_insert_side", "pick_place", "push",
    "reach", "window_close", "window_open",
)
# MT50: all 50 Meta-World tasks
MT50: tuple[str, ...] = ALL_TASK_NAMES


def benchmark_tasks(name: str) -> tuple[str, ...]:
    """The task list of ``"mt10"`` or ``"mt50"`` in task-id order; raises if a task of the set is not implemented."""
    if name == "mt10":
        missing = [t for t in MT10 if t not in TASKS]
        tasks = tuple(sorted(MT10, key=lambda t: TASKS[t].mtbench_id)) if not missing else MT10
    elif name == "mt50":
        missing = [] if len(TASKS) == NUM_METAWORLD_TASKS else [f"{NUM_METAWORLD_TASKS - len(TASKS)} tasks"]
        tasks = MT50
    else:
        raise ValueError(f"unknown Meta-World benchmark {name!r}; valid choices: ['mt10', 'mt50']")
    if missing:
        raise NotImplementedError(f"{name} needs tasks that are not implemented: {missing}")
    return tasks


def task_class(name: str) -> type[MetaWorldTask]:
    """The task definition for ``name``; raises with the valid choices otherwise."""
    if name in TASKS:
        return TASKS[name]
    raise ValueError(f"unknown Meta-World task {name!r}; valid choices: {sorted(TASKS)}")


__all__ = ["ALL_TASK_NAMES", "MT10", "MT50", "NUM_METAWORLD_TASKS", "TASKS", "benchmark_tasks", "task_class"]
