"""rl_games' KL-adaptive learning rate, applied on the device after every minibatch update or after every epoch."""

from __future__ import annotations

from typing import Any

import torch

from .base import TrainerHook

#: when the learning rate adapts: ``"minibatch"`` (after every update, on its KL) or ``"epoch"`` (after every
#: epoch, on the mean KL of its updates: rl_games' ``schedule_type: standard``)
PERIODS = ("minibatch", "epoch")


class AdaptiveLR(TrainerHook):
    """``lr /= factor`` if ``KL > 2 * kl_threshold``, ``lr *= factor`` if ``KL < kl_threshold / 2``, within
    ``[min_lr, max_lr]`` (rl_games ``AdaptiveScheduler``).

    ``period="minibatch"`` (default): after every minibatch update, on that update's KL (rl_games' "legacy" form).
    ``period="epoch"``: after every epoch, on the mean KL of the epoch's updates (rl_games' ``schedule_type:
    standard``, which MTBench's configs use; the loop then measures each minibatch's KL against the policy one epoch
    earlier, as rl_games does: ``loss.lr_schedule_type``, docs/training.md).

    ``KL`` is the ``kl`` metric (mtbench's losses: rl_games' analytic KL(new || reference) of the Gaussians); the
    learning rates are tensors changed in place (no host sync, graph-safe), and stay put on an update that was
    skipped (``skipped`` from :class:`~mtbench.trainer.hooks.NonFiniteGuard`) or whose KL is not finite. The
    learning rate lives in the optimizer, hence in its ``state_dict``.
    """

    name = "adaptive_lr"

    def __init__(
        self, kl_threshold: float = 0.008, min_lr: float = 1e-6, max_lr: float = 1e-2, factor: float = 1.5,
        period: str = "minibatch",
    ) -> None:
        if not (kl_threshold > 0 and 0 < min_lr <= max_lr and factor > 1):
            raise ValueError(f"AdaptiveLR needs kl_threshold > 0, 0 < min_lr <= max_lr, factor > 1; got "
                             f"{kl_threshold}, {min_lr}, {max_lr}, {factor}")
        if period not in PERIODS:
            raise ValueError(f"unknown AdaptiveLR period {period!r}; valid choices: {list(PERIODS)}")
        self.kl_threshold = float(kl_threshold)
        self.min_lr, self.max_lr, self.factor = float(min_lr), float(max_lr), float(factor)
        self.period = period

    def on_train_start(self, trainer: Any) -> None:
        for group in trainer.optimizer.param_groups:  # a tensor lr can be changed in place inside a graph
            if not isinstance(group["lr"], torch.Tensor):
                group["lr"] = torch.tensor(float(group["lr"]), device=group["params"][0].device)

    def on_update(self, trainer: Any, metrics: Any) -> None:
        if self.period == "minibatch":
            self._adapt(trainer, metrics.get("kl", None), metrics.get("skipped", None))

    def on_epoch_end(self, trainer: Any, metrics: Any) -> None:
        if self.period == "epoch":
            self._adapt(trainer, metrics.get("kl", None), None)

    def _adapt(self, trainer: Any, kl: torch.Tensor | None, skipped: torch.Tensor | None) -> None:
        if kl is None:
            return
        applied = torch.isfinite(kl)
        if skipped is not None:
            applied = applied & (skipped == 0)
        for group in trainer.optimizer.param_groups:
            lr = group["lr"]
            k = kl.to(lr.dtype)
            new_lr = torch.where(
                k > 2.0 * self.kl_threshold,
                (lr / self.factor).clamp_min(self.min_lr),
                torch.where(k < 0.5 * self.kl_threshold, (lr * self.factor).clamp_max(self.max_lr), lr),
            )
            lr.copy_(torch.where(applied, new_lr, lr))


__all__ = ["AdaptiveLR", "PERIODS"]
