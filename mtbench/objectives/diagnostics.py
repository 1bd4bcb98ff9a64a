"""Gradient-conflict diagnostics: pairwise cosine similarity of per-task actor and critic gradients."""

from __future__ import annotations

from typing import Sequence

import torch
from torchrl.objectives import LossModule

from .task_wrapper import DIAGNOSTIC_KEYS, TaskGradientWrapper

__all__ = ["DIAGNOSTIC_KEYS", "GradientDiagnostics"]


class GradientDiagnostics(TaskGradientWrapper):
    """Measure task-gradient conflicts without changing the gradients (use it with ``grad=none``).

    :meth:`backward` writes the plain gradient of the summed batch-mean loss terms (what
    ``compute_gradients`` does for an unwrapped ``reduction="mean"`` loss) and, every ``every`` updates,
    computes the per-task gradients of the actor terms w.r.t. the actor parameters and of the critic terms
    (``loss_critic`` of PPO, ``loss_qvalue`` of SAC, ...) w.r.t. the critic parameters (one batched backward
    each; terms found as in :class:`~mtbench.objectives.task_wrapper.TaskGradientWrapper`) and
    reports the mean / min / max pairwise cosine similarity over the tasks present in the minibatch as
    ``grad_cos_{actor,critic}_{mean,min,max}`` -- the measurement behind MTBench's finding that critic
    gradients conflict more than actor gradients. The keys carry the most recent measurement at every
    update (the first update is measured).

    Args:
        loss_module: a TorchRL loss with per-sample loss terms under ``reduction="none"`` (set here).
        num_tasks: K.
        every: measurement period in updates (>= 1).
        critic_keys: see :class:`~mtbench.objectives.task_wrapper.TaskGradientWrapper`.
    """

    needs_task_gradients = False

    def __init__(
        self,
        loss_module: LossModule,
        num_tasks: int,
        *,
        every: int = 100,
        critic_keys: Sequence[str] | None = None,
    ) -> None:
        if int(every) < 1:
            raise ValueError(f"GradientDiagnostics needs every >= 1, got {every}")
        super().__init__(
            loss_module,
            num_tasks,
            params="all",
            diagnostics_every=int(every),
            critic_keys=critic_keys,
        )

    def _group_loss(self, task_losses: torch.Tensor, batch_mean: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
        return batch_mean
