"""``make_gradient_method``: build the gradient-manipulation wrapper named in the config (``grad=<name>``)."""

from __future__ import annotations

from typing import Any, Callable

from torch import nn

from .cagrad import CAGrad
from .diagnostics import GradientDiagnostics
from .famo import FAMO
from .pcgrad import PCGrad

GRADIENT_METHODS: dict[str, Callable[..., nn.Module] | None] = {
    "none": None,
    "pcgrad": PCGrad,
    "cagrad": CAGrad,
    "famo": FAMO,
}


def make_gradient_method(name: str, loss_module: nn.Module, num_tasks: int, **kwargs: Any) -> nn.Module:
    """Wrap ``loss_module`` with the gradient method ``name`` (``none``, ``pcgrad``, ``cagrad``, ``famo``).

    ``kwargs`` are the method's arguments (the ``conf/grad/<name>.yaml`` entries other than ``name``):
    ``params``, ``diagnostics_every``, ``critic_keys``, ``task_loss_scale`` for every wrapper,
    plus ``reduction``/``seed`` (pcgrad), ``c``/``rescale``/``scale_by_num_tasks``/``solver_iters`` (cagrad),
    ``gamma``/``w_lr``/``epsilon``/``norm_w_grad``/``exp_losses`` (famo).

    ``none`` returns ``loss_module`` itself (its ``reduction`` is set back to ``"mean"`` if it was
    ``"none"``, so that summing its ``loss_*`` entries gives the usual loss), or, with
    ``diagnostics_every > 0``, a :class:`GradientDiagnostics` wrapper that measures gradient conflicts
    without changing the gradients. The returned module is what the trainer passes to
    ``compute_gradients`` and checkpoints (its ``state_dict`` holds FAMO's logits and optimiser state).
    """
    if name not in GRADIENT_METHODS:
        raise ValueError(f"unknown gradient method {name!r}; valid choices: {sorted(GRADIENT_METHODS)}")
    if name == "none":
        every = int(kwargs.pop("diagnostics_every", 0) or 0)
        kwargs.pop("params", None)  # nothing is manipulated
        allowed = {"critic_keys"}
        unknown = sorted(set(kwargs) - allowed)
        if unknown:
            valid = sorted(allowed | {"params", "diagnostics_every"})
            raise ValueError(f"grad=none got unexpected arguments {unknown}; valid: {valid}")
        if every > 0:
            return GradientDiagnostics(loss_module, num_tasks, every=every, **kwargs)
        if getattr(loss_module, "reduction", None) == "none":
            loss_module.reduction = "mean"
        return loss_module
    cls = GRADIENT_METHODS[name]
    assert cls is not None
    try:
        return cls(loss_module, num_tasks, **kwargs)
    except TypeError as err:
        raise ValueError(f"grad={name!r}: invalid arguments {sorted(kwargs)} ({err})") from err
