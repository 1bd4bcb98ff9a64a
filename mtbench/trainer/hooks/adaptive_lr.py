"""rl_games' KL-adaptive learning rate, applied on the device after every minibatch update."""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase

from .base import TrainerHook


class AdaptiveLR(TrainerHook):
    """After every minibatch update: ``lr /= factor`` if ``KL > 2 * kl_threshold``, ``lr *= factor`` if
    ``KL < kl_threshold / 2``, within ``[min_lr, max_lr]`` (rl_games ``AdaptiveScheduler``, "legacy" form).

    ``KL`` is the update's ``kl`` metric (mtbench's losses: rl_games' analytic KL(new || old) of the Gaussians);
    the learning rates are tensors changed in place (no host sync, graph-safe), and stay put on an update
    that was skipped (``skipped`` from :class:`~mtbench.trainer.hooks.NonFiniteGuard`) or whose KL is not
    finite. The learning rate lives in the optimizer, hence in its ``state_dict``.
    """

    name = "adaptive_lr"

    def __init__(
        self, kl_threshold: float = 0.008, min_lr: float = 1e-6, max_lr: float = 1e-2, factor: float = 1.5
    ) -> None:
        if not (kl_threshold > 0 and 0 < min_lr <= max_lr and factor > 1):
            raise ValueError(f"AdaptiveLR needs kl_threshold > 0, 0 < min_lr <= max_lr, factor > 1; got "
                             f"{kl_threshold}, {min_lr}, {max_lr}, {factor}")
        self.kl_threshold = float(kl_threshold)
        self.min_lr, self.max_lr, self.factor = float(min_lr), float(max_lr), float(factor)

    def on_train_start(self, trainer: Any) -> None:
        for group in trainer.optimizer.param_groups:  # a tensor lr can be changed in place inside a graph
            if not isinstance(group["lr"], torch.Tensor):
                group["lr"] = torch.tensor(float(group["lr"]), device=group["params"][0].device)

    def on_update(self, trainer: Any, metrics: TensorDictBase) -> None:
        kl = metrics.get("kl", None)
        if kl is None:
            return
        applied = torch.isfinite(kl)
        skipped = metrics.get("skipped", None)
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


__all__ = ["AdaptiveLR"]
