"""Per-task reductions of per-sample losses (masked means by ``task_id``, sync-free).

Every function here uses ``index_add`` on a ``[K]`` (or ``[K, T]``) buffer: no Python loop over tasks, no
``bincount`` (which needs the maximum id on the host), no ``nonzero``/``.item()``. Tasks absent from the
batch get count 0 and mean 0; callers use the ``present = count > 0`` mask to exclude them.
"""

from __future__ import annotations

import torch


def flat_task_ids(task_id: torch.Tensor, numel: int) -> torch.Tensor:
    """``task_id`` (``[*B]`` or ``[*B, 1]``, integer) as a flat int64 ``[N]`` tensor with ``N == numel``."""
    if task_id.dtype.is_floating_point or task_id.dtype == torch.bool:
        raise ValueError(f"task_id must be an integer tensor, got dtype {task_id.dtype}")
    flat = task_id.reshape(-1)
    if flat.numel() != numel:
        raise ValueError(
            f"task_id has {flat.numel()} entries (shape {tuple(task_id.shape)}) but the batch has {numel} samples"
        )
    return flat.long()


def check_task_ids(task_id: torch.Tensor, num_tasks: int) -> None:
    """Raise ``ValueError`` if an id is outside ``[0, num_tasks)``.

    Only runs on CPU tensors (the check needs the values on the host); on an accelerator an out-of-range id
    triggers the device-side assert of ``index_add`` instead.
    """
    if task_id.device.type != "cpu" or task_id.numel() == 0:
        return
    lo, hi = int(task_id.min()), int(task_id.max())
    if lo < 0 or hi >= num_tasks:
        raise ValueError(f"task_id values must lie in [0, {num_tasks}); got min {lo}, max {hi}")


def per_sample(value: torch.Tensor, numel: int, name: str = "loss") -> torch.Tensor:
    """Reshape a per-sample term to ``[N]``; trailing per-sample dims (e.g. ``[N, 1]``) are averaged."""
    if value.ndim == 0 and numel != 1:
        raise ValueError(f"{name!r} is a scalar: the wrapped loss must produce per-sample terms (reduction='none')")
    if value.numel() % numel != 0:
        raise ValueError(
            f"{name!r} has shape {tuple(value.shape)}, which does not hold one value per sample for {numel} samples"
        )
    flat = value.reshape(numel, -1)
    return flat[:, 0] if flat.shape[1] == 1 else flat.mean(-1)


def task_counts(task_id: torch.Tensor, num_tasks: int, weights: torch.Tensor | None = None) -> torch.Tensor:
    """Number (or total ``weights``) of samples of each task: ``[K]``, float."""
    dtype = weights.dtype if weights is not None else torch.get_default_dtype()
    src = weights if weights is not None else torch.ones(task_id.shape, dtype=dtype, device=task_id.device)
    return torch.zeros(num_tasks, dtype=dtype, device=task_id.device).index_add(0, task_id, src)


def task_sums(values: torch.Tensor, task_id: torch.Tensor, num_tasks: int) -> torch.Tensor:
    """Per-task sums of ``values`` (``[N]`` -> ``[K]`` or ``[N, T]`` -> ``[K, T]``); differentiable."""
    out = values.new_zeros((num_tasks, *values.shape[1:]))
    return out.index_add(0, task_id, values)


def task_means(
    values: torch.Tensor,
    task_id: torch.Tensor,
    num_tasks: int,
    weights: torch.Tensor | None = None,
    counts: torch.Tensor | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Masked per-task means ``sum_i m_ki w_i x_i / sum_i m_ki w_i`` and the per-task (weighted) counts.

    ``values``: ``[N]`` or ``[N, T]`` (several terms at once); ``task_id``: flat int64 ``[N]``;
    ``weights``: optional per-sample ``[N]`` weights (e.g. a validity mask). Absent tasks get mean 0.
    Differentiable w.r.t. ``values``.
    """
    if counts is None:
        counts = task_counts(task_id, num_tasks, weights.to(values.dtype) if weights is not None else None)
    w = weights.to(values.dtype) if weights is not None else None
    if w is not None:
        values = values * (w if values.ndim == 1 else w.unsqueeze(-1))
    sums = task_sums(values, task_id, num_tasks)
    denom = torch.where(counts > 0, counts, torch.ones_like(counts))
    if sums.ndim > 1:
        denom = denom.unsqueeze(-1)
    return sums / denom, counts


def weighted_mean(values: torch.Tensor, weights: torch.Tensor | None = None) -> torch.Tensor:
    """Mean over the first dim (``[N]`` or ``[N, T]``), optionally weighted: ``sum w x / max(sum w, 1)``.

    Matches TorchRL's masked ``reduction="mean"`` (``loss.sum() / mask.sum().clamp_min(1)``).
    """
    if weights is None:
        return values.mean(0)
    w = weights.to(values.dtype)
    num = (values * (w if values.ndim == 1 else w.unsqueeze(-1))).sum(0)
    return num / w.sum().clamp_min(1.0)
