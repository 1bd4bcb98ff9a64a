"""FAMO (Liu et al. 2023, "Fast Adaptive Multitask Optimization") as a loss-module wrapper, MTBench variant."""

from __future__ import annotations

import math
from typing import Any

import torch
from torchrl.objectives import LossModule

from .task_wrapper import TaskGradientWrapper


def famo_loss_coefficients(
    task_losses: torch.Tensor,
    logits: torch.Tensor,
    present: torch.Tensor | None = None,
    epsilon: float = 1e-2,
    min_losses: torch.Tensor | float = 0.0,
) -> torch.Tensor:
    """Coefficients ``lam [K]`` of the per-task losses in FAMO's parameter step (they sum to 1).

    ``L_FAMO = sum_k z_k log D_k / c`` with ``z = softmax(logits)``, ``D_k = l_k - l*_k + eps`` and
    ``c = sum_k z_k / D_k`` (detached) has gradient ``sum_k lam_k grad l_k`` with ``lam_k = z_k / (c D_k)``.
    Absent tasks get 0 (the others are renormalised). ``D`` is clamped to a tiny positive value so that a
    negative loss (use ``exp_losses``) cannot produce NaN.
    """
    d = (task_losses - min_losses + epsilon).clamp_min(torch.finfo(task_losses.dtype).tiny)
    z = torch.softmax(logits.to(task_losses.dtype), dim=-1)
    ratio = z / d
    if present is not None:
        ratio = torch.where(present, ratio, 0.0)
    return ratio / ratio.sum().clamp_min(torch.finfo(ratio.dtype).tiny)


def famo_logit_gradient(logits: torch.Tensor, delta: torch.Tensor, normalize: bool = True) -> torch.Tensor:
    """``J_softmax(logits)^T delta = z * (delta - z.delta)``, optionally divided by its norm (MTBench)."""
    z = torch.softmax(logits, dim=-1)
    grad = z * (delta - (z * delta).sum())
    if normalize:
        norm = torch.linalg.vector_norm(grad)
        grad = torch.where(norm > 0, grad / norm.clamp_min(torch.finfo(grad.dtype).tiny), 0.0)
    return grad


class FAMO(TaskGradientWrapper):
    """Fast adaptive multitask optimisation: per-task loss weights from the tasks' loss improvements.

    Parameter step: one backward pass of ``sum_k lam_k l_k`` (:func:`famo_loss_coefficients`) for the
    group, plus the plain mean of the other terms -- no per-task gradients, ``O(1)`` in K. Weight step
    (MTBench's ``FAMOA2CAgent``): after each minibatch, ``delta_k = log D_k(previous minibatch) - log
    D_k(this minibatch)`` (the first update compares with a zero loss, as MTBench does), the logit gradient
    ``J_softmax^T delta`` (normalised when ``norm_w_grad``), and one Adam step (``w_lr``, L2 weight decay
    ``gamma``, like ``torch.optim.Adam(weight_decay=gamma)``) -- weight moves toward tasks whose loss
    decreased least. Tasks absent from a minibatch get weight 0 and ``delta = 0``; their previous loss is
    kept. The logits, Adam moments and step count and the previous log-losses are buffers: they live on
    the device and are saved in ``state_dict``.

    Args:
        loss_module, num_tasks, params, diagnostics_every, critic_keys, task_loss_scale:
            see :class:`~mtbench.objectives.task_wrapper.TaskGradientWrapper`.
        gamma: weight decay of the logits (MTBench Meta-World: 1e-3).
        w_lr: Adam learning rate of the logits (1e-3).
        epsilon: ``eps`` in ``log(l + eps)`` (1e-2).
        norm_w_grad: normalise the logit gradient (MTBench: True).
        exp_losses: apply ``exp`` to the per-task losses first (MTBench's FAMO-GRPO on actor losses, which
            can be negative).
        betas, adam_eps: Adam hyper-parameters of the logit optimiser (torch defaults).
    """

    needs_task_gradients = False

    def __init__(
        self,
        loss_module: LossModule,
        num_tasks: int,
        *,
        gamma: float = 1e-3,
        w_lr: float = 1e-3,
        epsilon: float = 1e-2,
        norm_w_grad: bool = True,
        exp_losses: bool = False,
        betas: tuple[float, float] = (0.9, 0.999),
        adam_eps: float = 1e-8,
        **kwargs: Any,
    ) -> None:
        if epsilon <= 0:
            raise ValueError(f"FAMO epsilon must be > 0, got {epsilon}")
        if w_lr <= 0 or gamma < 0:
            raise ValueError(f"FAMO needs w_lr > 0 and gamma >= 0, got w_lr={w_lr}, gamma={gamma}")
        super().__init__(loss_module, num_tasks, **kwargs)
        self.gamma = float(gamma)
        self.w_lr = float(w_lr)
        self.epsilon = float(epsilon)
        self.norm_w_grad = bool(norm_w_grad)
        self.exp_losses = bool(exp_losses)
        self.betas = (float(betas[0]), float(betas[1]))
        self.adam_eps = float(adam_eps)
        device = next(iter(self.loss_module.parameters()), torch.empty(0)).device
        k = self.num_tasks
        self.register_buffer("famo_logits", torch.zeros(k, device=device))
        self.register_buffer("famo_exp_avg", torch.zeros(k, device=device))
        self.register_buffer("famo_exp_avg_sq", torch.zeros(k, device=device))
        self.register_buffer("famo_step", torch.zeros((), device=device))
        # MTBench starts from prev_loss = 0: log(0 + eps)
        self.register_buffer("famo_prev_log_loss", torch.full((k,), math.log(self.epsilon), device=device))

    @property
    def task_weights(self) -> torch.Tensor:
        """Current task weights ``softmax(logits)`` ``[K]``."""
        return torch.softmax(self.famo_logits, dim=-1)

    def _losses(self, task_losses: torch.Tensor) -> torch.Tensor:
        return task_losses.exp() if self.exp_losses else task_losses

    def _group_loss(self, task_losses: torch.Tensor, batch_mean: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
        losses = self._losses(task_losses)
        lam = famo_loss_coefficients(losses.detach(), self.famo_logits, present, self.epsilon)
        self.update_logits(losses.detach(), present)  # after lam: this minibatch uses the current weights
        return (lam * losses).sum()

    @torch.no_grad()
    def update_logits(self, task_losses: torch.Tensor, present: torch.Tensor | None = None) -> None:
        """FAMO's weight step from this minibatch's (transformed) per-task losses ``[K]`` (in place)."""
        if present is None:
            present = torch.ones_like(task_losses, dtype=torch.bool)
        log_loss = (task_losses.to(self.famo_logits.dtype) + self.epsilon).clamp_min(
            torch.finfo(self.famo_logits.dtype).tiny
        ).log()
        delta = torch.where(present, self.famo_prev_log_loss - log_loss, 0.0)
        self.famo_prev_log_loss.copy_(torch.where(present, log_loss, self.famo_prev_log_loss))
        grad = famo_logit_gradient(self.famo_logits, delta, self.norm_w_grad)
        self._adam_step(grad)

    def _adam_step(self, grad: torch.Tensor) -> None:
        # torch.optim.Adam (amsgrad=False, maximize=False) with L2 weight decay, on buffers
        beta1, beta2 = self.betas
        logits = self.famo_logits
        grad = grad + self.gamma * logits
        self.famo_step.add_(1.0)
        self.famo_exp_avg.lerp_(grad, 1.0 - beta1)
        self.famo_exp_avg_sq.mul_(beta2).addcmul_(grad, grad, value=1.0 - beta2)
        bias1 = 1.0 - torch.pow(beta1, self.famo_step)
        bias2 = 1.0 - torch.pow(beta2, self.famo_step)
        denom = self.famo_exp_avg_sq.sqrt() / bias2.sqrt() + self.adam_eps
        logits.sub_(self.w_lr * self.famo_exp_avg / (bias1 * denom))

    def _extra_metrics(self) -> dict[str, torch.Tensor]:
        return {"famo_weight": self.task_weights.detach()}
