"""Small sync-free tensor helpers shared by the multi-task policy-gradient losses."""

from __future__ import annotations

import torch

from ..utils.distributed import all_reduce_sum_


def _flat_task_id(task_id: torch.Tensor, numel: int) -> torch.Tensor:
    tid = task_id.reshape(-1)
    if tid.numel() != numel:
        raise ValueError(f"task_id has {tid.numel()} entries for {numel} per-sample values")
    return tid


def per_task_standardize(
    x: torch.Tensor,
    task_id: torch.Tensor,
    num_tasks: int,
    *,
    eps: float = 1e-8,
    unbiased: bool = True,
) -> torch.Tensor:
    """Standardise ``x`` within each task: ``(x - mean_t) / (std_t + eps)`` (MTBench ``actor_loss_mt``).

    ``x`` holds one value per sample (``[*B]`` or ``[*B, 1]``), ``task_id`` one index per sample. Statistics are computed with
    ``index_add_`` (no host sync, works for tasks absent from the batch). ``unbiased`` uses the
    ``n - 1`` denominator as ``torch.std`` does; a task with a single sample gets std 0 (not NaN).
    """
    flat = x.reshape(-1)
    tid = _flat_task_id(task_id, flat.numel())
    ones = torch.ones_like(flat)
    # statistics over every rank's samples (torchrun; single process: this process's)
    count = all_reduce_sum_(torch.zeros(num_tasks, dtype=flat.dtype, device=flat.device).index_add_(0, tid, ones))
    total = all_reduce_sum_(torch.zeros(num_tasks, dtype=flat.dtype, device=flat.device).index_add_(0, tid, flat))
    mean = total / count.clamp_min(1.0)
    centered = flat - mean[tid]
    sq = all_reduce_sum_(
        torch.zeros(num_tasks, dtype=flat.dtype, device=flat.device).index_add_(0, tid, centered * centered))
    denom = (count - 1.0).clamp_min(1.0) if unbiased else count.clamp_min(1.0)
    std = (sq / denom).sqrt()
    return (centered / (std[tid] + eps)).reshape(x.shape)


def per_task_mean(x: torch.Tensor, task_id: torch.Tensor, num_tasks: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-task mean of per-sample values ``x[*B]`` and the per-task counts (both ``[K]``; mean 0 if absent)."""
    flat = x.reshape(-1)
    tid = _flat_task_id(task_id, flat.numel())
    count = torch.zeros(num_tasks, dtype=flat.dtype, device=flat.device).index_add_(0, tid, torch.ones_like(flat))
    total = torch.zeros(num_tasks, dtype=flat.dtype, device=flat.device).index_add_(0, tid, flat)
    return total / count.clamp_min(1.0), count


def bounds_loss(mu: torch.Tensor, soft_bound: float = 1.1) -> torch.Tensor:
    """rl_games ``bound_loss``: ``sum_j relu(mu_j - b)^2 + relu(-b - mu_j)^2`` over the action dim -> ``[*B, 1]``."""
    high = (mu - soft_bound).clamp_min(0.0) ** 2
    low = (mu + soft_bound).clamp_max(0.0) ** 2
    return (high + low).sum(-1, keepdim=True)


def gaussian_policy_kl(
    mu: torch.Tensor, sigma: torch.Tensor, old_mu: torch.Tensor, old_sigma: torch.Tensor
) -> torch.Tensor:
    """rl_games ``policy_kl(mu, sigma, old_mu, old_sigma)``: mean over samples of
    ``sum_j log(old_sigma/sigma + 1e-5) + (sigma^2 + (old_mu - mu)^2) / (2 (old_sigma^2 + 1e-5)) - 1/2``,
    i.e. KL(new || old) of diagonal Gaussians (used by the KL-adaptive learning rate)."""
    c1 = torch.log(old_sigma / sigma + 1e-5)
    c2 = (sigma**2 + (old_mu - mu) ** 2) / (2.0 * (old_sigma**2 + 1e-5))
    return (c1 + c2 - 0.5).sum(-1).mean()
