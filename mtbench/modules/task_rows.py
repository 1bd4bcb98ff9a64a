"""Per-sample rows of a per-task table (``table[task_id]``) with a matmul backward instead of an indexed scatter."""

from __future__ import annotations

import torch


class _TaskRows(torch.autograd.Function):
    """``table.index_select(0, task_id)``; backward ``one_hot(task_id)^T @ grad`` (one GEMM, deterministic)."""

    generate_vmap_rule = True

    @staticmethod
    def forward(table: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        return table.index_select(0, task_id)

    @staticmethod
    def setup_context(ctx, inputs, output) -> None:
        table, task_id = inputs
        ctx.num_rows = table.shape[0]
        ctx.save_for_backward(task_id)

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> tuple[torch.Tensor, None]:
        (task_id,) = ctx.saved_tensors
        # compare with arange rather than F.one_hot, which checks the ids with .item() on some devices
        rows = torch.arange(ctx.num_rows, device=task_id.device)
        onehot = (task_id.unsqueeze(-1) == rows).to(grad.dtype)  # [B, K]
        flat = grad.reshape(grad.shape[0], -1)
        return torch.matmul(onehot.t(), flat).reshape(ctx.num_rows, *grad.shape[1:]), None


def task_rows(table: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
    """``table[task_id]`` for a per-task ``table [K, ...]`` and integer ``task_id [B]`` -> ``[B, ...]``.

    Same forward (an exact gather); the backward sums the gradient rows of every task with one
    ``one_hot(task_id)^T @ grad`` matmul. Autograd's own backward of ``table[task_id]`` scatters with
    ``index_put_(accumulate=True)``, which on CUDA walks the ``~B / K`` duplicates of each of the ``K`` indices
    serially in one warp per task (pytorch/pytorch#41162): with ``K = 10`` tasks and ``B = 16,384`` samples, 10 warps
    on the whole GPU.
    """
    return _TaskRows.apply(table, task_id)
