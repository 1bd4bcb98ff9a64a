"""Skip non-finite updates on the device and stop a run whose updates are all non-finite."""

from __future__ import annotations

import warnings
from typing import Any

import torch
from tensordict import TensorDictBase

from ...objectives.gradients import is_loss_key, total_loss
from .base import TrainerHook


class NonFiniteGuard(TrainerHook):
    """A minibatch update whose total loss or gradient norm is not finite is skipped *on the device*: the
    optimizer's ``found_inf`` flag (honoured by fused Adam) leaves parameters and moments untouched, without a
    host sync. The update's metric ``skipped`` (1/0) is added for the other hooks (the adaptive learning rate
    does not move on a skipped update). Per iteration (``trainer.updates_per_iteration`` updates; an iteration
    without updates counts neither way): ``train/skipped_updates`` (count),
    ``train/skipped_updates_total``, a ``RuntimeWarning``; after ``max_streak`` consecutive iterations in which
    every update was skipped, ``RuntimeError``.

    Args:
        max_streak: iterations of only non-finite updates before the run stops (``max_nonfinite_iterations``).
    """

    name = "nonfinite_guard"

    def __init__(self, max_streak: int = 10) -> None:
        if int(max_streak) < 1:
            raise ValueError(f"max_nonfinite_iterations must be >= 1, got {max_streak}")
        self.max_streak = int(max_streak)
        self.skipped_total = 0
        self.streak = 0

    def on_train_start(self, trainer: Any) -> None:
        optimizer = trainer.optimizer
        if not (optimizer.defaults.get("fused") or getattr(optimizer, "honours_found_inf", False)):
            raise TypeError(
                f"NonFiniteGuard needs an optimizer whose step honours found_inf (fused=True Adam/AdamW/SGD, or "
                f"mtbench.trainer.SkipOnFoundInf optimizers such as its RAdam); got {type(optimizer).__name__} with "
                f"fused={optimizer.defaults.get('fused')}"
            )

    def before_optimizer_step(self, trainer: Any, metrics: TensorDictBase) -> None:
        finite = torch.isfinite(metrics["grad_norm"])
        if any(is_loss_key(k) for k in metrics.keys()):
            finite = finite & torch.isfinite(total_loss(metrics))
        skipped = (~finite).to(torch.float32)
        trainer.optimizer.found_inf = skipped
        metrics.set("skipped", skipped)

    def on_iteration_end(self, trainer: Any, metrics: dict[str, float]) -> None:
        updates = trainer.updates_per_iteration
        if updates == 0:  # an iteration without updates (an off-policy loop's warm-up) leaves the streak as it is
            metrics["train/skipped_updates"] = 0.0
            metrics["train/skipped_updates_total"] = float(self.skipped_total)
            return
        skipped = int(round(metrics.pop("train/skipped", 0.0) * updates))
        self.skipped_total += skipped
        self.streak = self.streak + 1 if skipped == updates else 0
        metrics["train/skipped_updates"] = float(skipped)
        metrics["train/skipped_updates_total"] = float(self.skipped_total)
        if skipped:
            warnings.warn(
                f"iteration {trainer.iteration}: {skipped}/{updates} minibatch updates skipped (non-finite loss or "
                "gradient)",
                RuntimeWarning,
                stacklevel=2,
            )
        if self.streak >= self.max_streak:
            raise RuntimeError(
                f"every update of the last {self.streak} iterations was non-finite (NaN/Inf loss or gradient); "
                "stopping. Check the env (physics blow-up) and the normalisers."
            )

    def state_dict(self) -> dict[str, Any]:
        return {"skipped_total": self.skipped_total, "streak": self.streak}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.skipped_total = int(state["skipped_total"])
        self.streak = int(state["streak"])


__all__ = ["NonFiniteGuard"]
