"""The one entry point the trainer uses to turn a batch into parameter gradients."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from torchrl.objectives import LossModule


def is_loss_key(key: object) -> bool:
    """Whether an entry of a loss output is a loss term: ``loss_*`` (TorchRL's actor-critic losses) or ``loss``
    (TorchRL's single-term losses, e.g. ``DQNLoss``)."""
    return isinstance(key, str) and (key == "loss" or key.startswith("loss_"))


def total_loss(loss_td: TensorDictBase) -> torch.Tensor:
    """Sum of all loss terms (``loss_*`` and ``loss`` entries) of a loss output."""
    terms = [v for k, v in loss_td.items() if is_loss_key(k)]
    if not terms:
        raise ValueError(f"loss output has no 'loss' or 'loss_*' entry; keys: {list(loss_td.keys())}")
    return torch.stack([t.sum() if t.ndim else t for t in terms]).sum()


def compute_gradients(loss_module: LossModule, batch: TensorDictBase) -> TensorDictBase:
    """Write ``.grad`` for ``loss_module``'s parameters from ``batch`` and return detached metrics.

    Loss modules that manipulate gradients (PCGrad, CAGrad, ...) define ``backward(batch)`` and are called
    through it; any other loss is reduced by summing its loss terms (``loss_*`` and ``loss`` entries).
    """
    backward = getattr(loss_module, "backward", None)
    if callable(backward):
        return backward(batch)
    out = loss_module(batch)
    total_loss(out).backward()
    return out.detach()
