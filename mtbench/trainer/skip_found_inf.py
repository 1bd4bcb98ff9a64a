"""Optimizers that skip a step on the device when ``found_inf`` is set, like fused Adam (for non-fused ones, e.g.
RAdam, which MT-PQN uses)."""

from __future__ import annotations

from typing import Any, Callable

import torch


class SkipOnFoundInf(torch.optim.Optimizer):
    """Mixin for an optimizer (``class RAdam(SkipOnFoundInf, torch.optim.RAdam)``): when the attribute
    ``found_inf`` is a tensor (set by :class:`~mtbench.trainer.hooks.NonFiniteGuard` before every step), a step with ``found_inf != 0`` leaves the
    parameters and the optimizer state (moments, step counts) as they were, without a host synchronisation: the
    step runs and ``torch.where`` restores the snapshot taken before it. State created by a skipped first step is
    reset to zeros (its initial value).

    Costs one copy of the parameters and of the state tensors per step (cheap for the small Q networks of PQN).
    """

    honours_found_inf = True
    found_inf: torch.Tensor | None = None

    @torch.no_grad()
    def step(self, closure: Callable[[], Any] | None = None) -> Any:
        found_inf = self.found_inf
        if found_inf is None:
            return super().step(closure)
        params = [p for group in self.param_groups for p in group["params"] if p.grad is not None]
        saved = [(p.detach().clone(), {k: v.clone() for k, v in self.state[p].items() if isinstance(v, torch.Tensor)})
                 for p in params]
        out = super().step(closure)
        skip = found_inf.reshape(()) != 0
        for p, (value, state) in zip(params, saved, strict=True):
            p.copy_(torch.where(skip.to(p.device), value, p))
            for key, current in self.state[p].items():
                if isinstance(current, torch.Tensor):
                    before = state.get(key)
                    before = torch.zeros_like(current) if before is None else before
                    current.copy_(torch.where(skip.to(current.device), before, current))
        return out


class RAdam(SkipOnFoundInf, torch.optim.RAdam):
    """``torch.optim.RAdam`` that honours ``found_inf`` (:class:`SkipOnFoundInf`)."""


__all__ = ["RAdam", "SkipOnFoundInf"]
