"""Per-task running mean / variance, updated on the device without host synchronisation."""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from ..utils.distributed import all_reduce_sum_


class PerTaskRunningMeanStd(nn.Module):
    """Running mean and (population) variance of ``D``-dimensional data, one set of statistics per task.

    Buffers (float64, so that counts in the billions stay exact enough):

    * ``count`` ``[K]``: number of samples seen per task,
    * ``mean`` ``[K, D]``, ``var`` ``[K, D]``: running mean and population variance per task
      (``var`` starts at 1 and ``mean`` at 0, so an unseen task is normalised by the identity).

    :meth:`update` merges the statistics of a batch into the running ones with the parallel-variance
    formula (Chan et al.): per task, ``n = n_a + n_b``, ``mean = mean_a + delta * n_b / n`` and
    ``M2 = var_a n_a + var_b n_b + delta^2 n_a n_b / n``. Batch sums are gathered with ``index_add_`` so
    the update never reads a value back to the host (no ``.item()``, no ``nonzero()``); non-finite rows
    (physics blow-ups) are ignored. After any sequence of updates ``mean``/``var`` equal the mean and
    population variance of all finite rows seen per task (up to float rounding).

    Args:
        num_tasks: K.
        dim: D, the feature size. ``0`` leaves the statistics uninitialised: they are created with the
            right size at the first :meth:`update` or when a state dict is loaded.
        eps: added to the variance in :meth:`normalize` / :meth:`denormalize`.
        clip: optional symmetric clamp applied to normalised values (rl_games uses 5 for values; the
            MTBench observation normaliser uses none).
        device: where the buffers live.
    """

    count: torch.Tensor
    mean: torch.Tensor
    var: torch.Tensor

    def __init__(
        self,
        num_tasks: int,
        dim: int,
        *,
        eps: float = 1e-8,
        clip: float | None = None,
        device: torch.device | str | None = None,
    ) -> None:
        super().__init__()
        if num_tasks < 1:
            raise ValueError(f"num_tasks must be >= 1, got {num_tasks}")
        if dim < 0:
            raise ValueError(f"dim must be >= 0, got {dim}")
        self.num_tasks = int(num_tasks)
        self.eps = float(eps)
        self.clip = None if clip is None else float(clip)
        self.register_buffer("count", torch.zeros(num_tasks, dtype=torch.float64, device=device))
        self.register_buffer("mean", torch.zeros(num_tasks, dim, dtype=torch.float64, device=device))
        self.register_buffer("var", torch.ones(num_tasks, dim, dtype=torch.float64, device=device))

    @property
    def dim(self) -> int:
        """Feature size D (0 while uninitialised)."""
        return int(self.mean.shape[-1])

    def _materialize(self, dim: int) -> None:
        if self.dim == dim:
            return
        if self.dim != 0:
            raise ValueError(f"PerTaskRunningMeanStd has dim={self.dim}, got data with {dim} features")
        device = self.count.device
        self.mean = torch.zeros(self.num_tasks, dim, dtype=torch.float64, device=device)
        self.var = torch.ones(self.num_tasks, dim, dtype=torch.float64, device=device)

    @staticmethod
    def _flatten(x: torch.Tensor, task_id: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        if task_id.ndim == x.ndim and task_id.shape[-1] == 1:
            task_id = task_id.squeeze(-1)
        if task_id.shape != x.shape[:-1]:
            raise ValueError(f"task_id shape {tuple(task_id.shape)} does not match data batch {tuple(x.shape[:-1])}")
        return x.reshape(-1, x.shape[-1]), task_id.reshape(-1)

    @torch.no_grad()
    def update(self, x: torch.Tensor, task_id: torch.Tensor, mask: torch.Tensor | None = None) -> None:
        """Merge the statistics of ``x[..., D]`` (rows labelled by ``task_id[...]``) into the running ones.

        ``mask`` (bool, batch-shaped, optional) selects the rows to use; non-finite rows are always skipped.
        """
        self._materialize(x.shape[-1])
        if mask is not None and mask.ndim == x.ndim and mask.shape[-1] == 1:
            mask = mask.squeeze(-1)
        x, tid = self._flatten(x, task_id)
        x = x.to(torch.float64)
        finite = torch.isfinite(x).all(-1)
        if mask is not None:
            finite = finite & mask.reshape(-1).to(device=finite.device, dtype=torch.bool)
        w = finite.to(torch.float64)
        x = torch.where(finite.unsqueeze(-1), x, torch.zeros((), dtype=x.dtype, device=x.device))
        k, d = self.num_tasks, self.dim
        # the batch's statistics over every rank's rows (torchrun; single process: this process's rows)
        n_b = all_reduce_sum_(torch.zeros(k, dtype=torch.float64, device=x.device).index_add_(0, tid, w))
        s_b = all_reduce_sum_(torch.zeros(k, d, dtype=torch.float64, device=x.device).index_add_(0, tid, x))
        safe_n_b = n_b.clamp_min(1.0).unsqueeze(-1)
        mean_b = s_b / safe_n_b
        centered = (x - mean_b[tid]) * w.unsqueeze(-1)
        m2_b = all_reduce_sum_(
            torch.zeros(k, d, dtype=torch.float64, device=x.device).index_add_(0, tid, centered * centered))

        n_a = self.count
        n = n_a + n_b
        safe_n = n.clamp_min(1.0).unsqueeze(-1)
        delta = mean_b - self.mean
        new_mean = self.mean + delta * (n_b.unsqueeze(-1) / safe_n)
        m2 = self.var * n_a.unsqueeze(-1) + m2_b + delta * delta * (n_a * n_b).unsqueeze(-1) / safe_n
        seen = (n > 0).unsqueeze(-1)
        self.mean.copy_(torch.where(seen, new_mean, self.mean))
        self.var.copy_(torch.where(seen, m2 / safe_n, self.var))
        self.count.copy_(n)

    def _stats(self, x: torch.Tensor, task_id: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        if task_id.ndim == x.ndim and task_id.shape[-1] == 1:
            task_id = task_id.squeeze(-1)
        mean = self.mean.to(x.dtype)[task_id]
        std = (self.var + self.eps).sqrt().to(x.dtype)[task_id]
        return mean, std

    def normalize(self, x: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        """``(x - mean[task]) / sqrt(var[task] + eps)``, clamped to ``±clip`` when ``clip`` is set."""
        if self.dim == 0:
            raise RuntimeError("PerTaskRunningMeanStd.normalize called before any update (dim unknown)")
        mean, std = self._stats(x, task_id)
        y = (x - mean) / std
        if self.clip is not None:
            y = y.clamp(-self.clip, self.clip)
        return y

    def denormalize(self, y: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        """Inverse of :meth:`normalize`: ``y * sqrt(var[task] + eps) + mean[task]`` (``y`` clamped first if
        ``clip`` is set, as rl_games does)."""
        if self.dim == 0:
            raise RuntimeError("PerTaskRunningMeanStd.denormalize called before any update (dim unknown)")
        if self.clip is not None:
            y = y.clamp(-self.clip, self.clip)
        mean, std = self._stats(y, task_id)
        return y * std + mean

    def _load_from_state_dict(
        self,
        state_dict: dict[str, Any],
        prefix: str,
        local_metadata: dict[str, Any],
        strict: bool,
        missing_keys: list[str],
        unexpected_keys: list[str],
        error_msgs: list[str],
    ) -> None:
        mean = state_dict.get(prefix + "mean")
        if isinstance(mean, torch.Tensor) and self.dim == 0 and mean.shape[-1] != 0:
            self._materialize(int(mean.shape[-1]))
        super()._load_from_state_dict(
            state_dict, prefix, local_metadata, strict, missing_keys, unexpected_keys, error_msgs
        )

    def extra_repr(self) -> str:
        return f"num_tasks={self.num_tasks}, dim={self.dim}, eps={self.eps}, clip={self.clip}"
