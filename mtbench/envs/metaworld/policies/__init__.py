"""Scripted (hand-written) policies that solve Meta-World tasks from the 39-d state observation.

Each module defines ``policy(obs: Tensor[N, 39]) -> Tensor[N, 4]`` for one task (name = module name). They are
batched, stateless functions of the observation (like Meta-World's own scripted policies) and serve as
solvability checks for the task definitions and as demonstrations.
"""

from __future__ import annotations

import importlib
from typing import Callable

import torch

ScriptedPolicy = Callable[[torch.Tensor], torch.Tensor]


def scripted_policy(task: str) -> ScriptedPolicy:
    """The scripted policy of ``task``; raises ``ValueError`` naming the tasks that have one."""
    import pkgutil

    names = sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))
    if task not in names:
        raise ValueError(f"no scripted policy for task {task!r}; valid choices: {names}")
    return importlib.import_module(f"{__name__}.{task}").policy
