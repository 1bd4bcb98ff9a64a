"""``make_env``: build any named mtbench setting."""

from __future__ import annotations

import inspect
import numbers
import re
from typing import Any, Sequence

import torch
from torchrl.envs import EnvBase, TransformedEnv

from .discrete_actions import ACTION_MODES, DiscreteActions, check_bins
from .metaworld import ALL_TASK_NAMES, MetaWorldEnv, benchmark_tasks
from .parkour.settings import SETTINGS as PARKOUR_SETTINGS
from .parkour.terrains import TERRAIN_NAMES as PARKOUR_TERRAINS

# name -> (benchmark, resample object/goal at every reset?)
METAWORLD_SETS: dict[str, tuple[str, bool]] = {
    "mt10": ("mt10", False),
    "mt10_rand": ("mt10", True),
    "mt50": ("mt50", False),
    "mt50_rand": ("mt50", True),
}


def split_envs(num_envs: int, num_tasks: int) -> list[int]:
    """Split ``num_envs`` over ``num_tasks`` contiguous blocks as MTBench does (first blocks get the remainder):
    24,576 over MT10 gives ``[2458]*6 + [2457]*4``."""
    if num_envs < num_tasks:
        raise ValueError(f"num_envs={num_envs} is smaller than the number of tasks ({num_tasks}); "
                         "every task needs at least one env")
    base, rem = divmod(num_envs, num_tasks)
    return [base + 1] * rem + [base] * (num_tasks - rem)


def _positive_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool) and value >= 1


def setting_names() -> list[str]:
    """Every name ``make_env`` accepts as a string (sets and single tasks)."""
    return sorted(METAWORLD_SETS) + sorted(ALL_TASK_NAMES) + sorted(PARKOUR_SETTINGS) + sorted(PARKOUR_TERRAINS)


def metaworld_tasks(name: str | Sequence[str]) -> list[str]:
    """The Meta-World tasks of ``make_env(name)`` in the order of their task ids (``task_id``, one-hot slots): a set's
    tasks in task-id order, ``[name]`` for one task, a list as given. Raises with the valid choices otherwise."""
    if isinstance(name, str):
        if name in METAWORLD_SETS:
            return list(benchmark_tasks(METAWORLD_SETS[name][0]))
        if name in ALL_TASK_NAMES:
            return [name]
        raise ValueError(f"unknown Meta-World env name {name!r}; valid choices: {sorted(METAWORLD_SETS)}, a task name "
                         "or a list of task names")
    tasks = list(name)
    unknown = [t for t in tasks if t not in ALL_TASK_NAMES]
    if not tasks or unknown:
        raise ValueError(f"unknown task names {unknown}; valid choices: {sorted(ALL_TASK_NAMES)}" if unknown
                         else "the task list is empty")
    return tasks


def is_parkour(name: str | Sequence[str]) -> bool:
    """Whether ``make_env(name)`` builds a Parkour env (a setting, a terrain name or a list of terrain names)."""
    if isinstance(name, str):
        return name in PARKOUR_SETTINGS or name in PARKOUR_TERRAINS
    names = list(name)
    return bool(names) and all(n in PARKOUR_TERRAINS for n in names)


def make_env(
    name: str | Sequence[str],
    num_envs: int | Sequence[int] | None = None,
    device: torch.device | str | None = None,
    *,
    actions: str = "continuous",
    bins: int | None = None,
    **overrides: Any,
) -> EnvBase:
    """Build a batched multi-task env.

    Args:
        name: a Meta-World setting (``"mt10"``, ``"mt10_rand"``, ``"mt50"``, ``"mt50_rand"``), one task name
            (``"reach"``) or a list of task names (its own multi-task setting; ``rand`` defaults to True there); or a
            Parkour setting (``"parkour_flat"``, ``"parkour_easy"``, ``"parkour_hard"``, ``"parkour_hard_cl"``), one
            terrain name or a list of terrain names (see :func:`~mtbench.envs.parkour.settings.make_parkour_env`).
        num_envs: total worlds (split evenly, MTBench style) or, for Meta-World, one count per task. Defaults to 1
            per task (per terrain column for Parkour).
        device: torch device (default: ``cuda`` if available, else ``cpu``).
        actions: ``"continuous"`` (default) or ``"discrete"``: MTBench's bang-off-bang variant of a Meta-World
            setting, the env wrapped in :class:`~mtbench.envs.discrete_actions.DiscreteActions` (integer bins
            ``[N, 4]``, ``Categorical(bins)`` action spec, bin ``b`` -> ``-1 + 2 b / (bins - 1)`` per dimension).
        bins: values per action dimension with ``actions="discrete"`` (default 3: ``{-1, 0, +1}``).
        **overrides: forwarded to :class:`~mtbench.envs.metaworld.MetaWorldEnv` (``seed``, ``rand``,
            ``reward_scale``, ``episode_length``, ``substeps``, ``robot_collision``, ``box_box_collider``, ...) or to
            ``make_parkour_env`` (``num_rows``, ``terrain_seed``, ``seed``, ``episode_length``,
            ``terrain_collision``, ``robot_inertia``, ``terrain_representation``, ...).
    """
    if device is None:
        device = "cuda" if torch.cuda.is_available() else "cpu"
    if not re.fullmatch(r"cpu|cuda(:\d+)?", str(device)):
        raise ValueError(f"device={str(device)!r} is not supported; valid choices: 'cpu', 'cuda', 'cuda:<index>'")
    if actions not in ACTION_MODES:
        raise ValueError(f"unknown actions {actions!r}; valid choices: {list(ACTION_MODES)}")
    if actions == "continuous" and bins is not None:
        raise ValueError(f"bins={bins!r} is only used with actions='discrete' (got actions='continuous')")
    if actions == "discrete":
        bins = check_bins(3 if bins is None else bins)
        if is_parkour(name):
            raise ValueError(f"actions='discrete' is available for Meta-World settings only; got the Parkour "
                             f"setting {name!r}")
        env = make_env(name, num_envs, device, **overrides)
        discrete = TransformedEnv(env, DiscreteActions(bins))
        discrete.__dict__["_torchrl_native_autoreset"] = True  # TorchRL reads it from the instance
        return discrete
    if is_parkour(name):
        from .parkour.settings import make_parkour_env

        return make_parkour_env(name, num_envs, device, **overrides)
    if isinstance(name, str):
        if name not in METAWORLD_SETS and name not in ALL_TASK_NAMES:
            raise ValueError(f"unknown env name {name!r}; valid choices: {setting_names()} or a list of task names")
        if name in METAWORLD_SETS:
            overrides.setdefault("rand", METAWORLD_SETS[name][1])
    tasks = metaworld_tasks(name)
    if num_envs is None:
        counts = [1] * len(tasks)
    elif _positive_int(num_envs):
        counts = split_envs(num_envs, len(tasks))
    else:
        if isinstance(num_envs, (str, bytes)) or not isinstance(num_envs, Sequence) or not all(
            _positive_int(c) for c in num_envs
        ):
            raise ValueError(f"num_envs must be a positive integer (split over the tasks) or a list of one positive "
                             f"integer per task; got {num_envs!r}")
        counts = [int(c) for c in num_envs]
        if len(counts) != len(tasks):
            raise ValueError(f"{len(counts)} env counts given for {len(tasks)} tasks {tasks}; give one per task")
    accepted = set(inspect.signature(MetaWorldEnv.__init__).parameters) - {"self", "tasks", "task_counts", "device"}
    unknown_overrides = sorted(set(overrides) - accepted)
    if unknown_overrides:
        raise ValueError(f"unknown Meta-World env overrides {unknown_overrides}; valid: {sorted(accepted)}")
    return MetaWorldEnv(tasks, counts, device=device, **overrides)
