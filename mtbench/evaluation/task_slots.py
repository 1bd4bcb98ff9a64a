"""Evaluating a Meta-World policy on some of its run's tasks: the env's tasks mapped onto the policy's task slots.

A multi-task policy knows a task by its slot: the position of the task's one-hot in the observation, its row of the
per-task statistics and, for some architectures, its head or its description. The slots are the run's tasks in their
order. An eval env built from another task list numbers its tasks afresh; :class:`TaskSlots` turns the env's task
ids and one-hots back into the policy's slots, so that ``examples/eval.py env.name=[pick_place]`` evaluates the
pick_place of an MT10 policy. Parkour keeps its 21 canonical slots for any terrains and needs none of this.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import torch
from omegaconf import OmegaConf

from ..envs import METAWORLD_SETS, is_parkour, metaworld_tasks
from ..envs.metaworld import task_class
from .args import EvalArgumentError


@dataclasses.dataclass(frozen=True)
class TaskSlots:
    """``slots[i]``: the trained policy's slot of the eval env's task ``i``; ``trained_tasks``: the run's tasks, in
    slot order."""

    trained_tasks: tuple[str, ...]
    slots: tuple[int, ...]
    #: the slot table per device, made once (no host-to-device copy per env step)
    _tables: dict[torch.device, torch.Tensor] = dataclasses.field(default_factory=dict, init=False, repr=False,
                                                                   compare=False)

    @property
    def num_slots(self) -> int:
        return len(self.trained_tasks)

    @property
    def descriptions(self) -> list[str]:
        """The trained tasks' descriptions (architectures that encode them, e.g. CARE), in slot order."""
        return [task_class(t).description for t in self.trained_tasks]

    def policy_input(self, obs: torch.Tensor, task_id: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The env's ``observation`` (state, then its own one-hot of ``len(slots)``) and ``task_id`` as the policy
        saw them in training: the one-hot and the id of the task's slot."""
        table = self._tables.get(task_id.device)
        if table is None:
            table = self._tables[task_id.device] = torch.tensor(self.slots, device=task_id.device)
        slot = table[task_id]
        one_hot = torch.nn.functional.one_hot(slot, self.num_slots).to(obs.dtype)
        return torch.cat([obs[..., : obs.shape[-1] - len(self.slots)], one_hot], dim=-1), slot


def task_slots(trained_on: Any, name: Any) -> TaskSlots | None:
    """Where the tasks of ``env.name=name`` sit among the slots of a policy trained on ``env.name=trained_on``:
    ``None`` when they are the same tasks in the same order (``mt10`` for an ``mt10_rand`` run) or for Parkour;
    an :class:`EvalArgumentError` naming the valid tasks when ``name`` has a task the run did not train on."""

    def plain(value: Any) -> Any:
        return list(value) if OmegaConf.is_list(value) else value

    trained_on, name = plain(trained_on), plain(name)
    if is_parkour(trained_on):
        return None
    try:
        tasks = metaworld_tasks(name)
    except ValueError as err:
        raise EvalArgumentError(f"env.name={name}: {err}") from None
    trained = metaworld_tasks(trained_on)
    if tasks == trained:
        return None
    foreign = [t for t in tasks if t not in trained]
    if foreign:
        same = [s for s in sorted(METAWORLD_SETS) if metaworld_tasks(s) == trained]
        raise EvalArgumentError(
            f"env.name={name} has tasks this policy was not trained on: {foreign}; its task slots are the "
            f"{len(trained)} tasks of env.name={trained_on}: valid choices: "
            + " or ".join(same + ["a list of some of them, in any order"])
            + (f" ({', '.join(trained)})" if len(trained) <= 10 else ""))
    if len(set(tasks)) != len(tasks):
        raise EvalArgumentError(f"env.name={name} names a task twice; give each task once")
    return TaskSlots(tuple(trained), tuple(trained.index(t) for t in tasks))


__all__ = ["TaskSlots", "task_slots"]
