"""Per-task gradient matrices: one batched backward pass, flattening, Gram matrix and cosine statistics."""

from __future__ import annotations

import warnings
from typing import Sequence

import torch

_BATCHED_FALLBACK_WARNED = False


def grads_or_zeros(
    output: torch.Tensor | None, params: Sequence[torch.Tensor], *, retain_graph: bool = True
) -> list[torch.Tensor]:
    """``d output / d params`` with zeros for parameters ``output`` does not depend on."""
    if output is None or not output.requires_grad or not params:
        return [torch.zeros_like(p) for p in params]
    grads = torch.autograd.grad(output, list(params), retain_graph=retain_graph, allow_unused=True)
    return [torch.zeros_like(p) if g is None else g for p, g in zip(params, grads)]


def batched_per_task_gradients(task_losses: torch.Tensor, params: Sequence[torch.Tensor]) -> torch.Tensor | None:
    """Gradients of each of the ``K`` entries of ``task_losses`` w.r.t. ``params`` as a ``[K, P]`` matrix, in one
    call ``torch.autograd.grad(task_losses, params, grad_outputs=eye(K), is_grads_batched=True)`` (vmap over the
    backward pass; the graph is retained). ``None`` (with a warning, once per process) when an operation in the
    graph has no batching rule, e.g. the backward of a ``torch.compile``d network. Rows of tasks that do not reach
    a parameter are zero."""
    global _BATCHED_FALLBACK_WARNED
    params = list(params)
    k = task_losses.numel()
    if not task_losses.requires_grad:
        return task_losses.new_zeros(k, sum(p.numel() for p in params))
    eye = torch.eye(k, dtype=task_losses.dtype, device=task_losses.device)
    try:
        grads = torch.autograd.grad(
            task_losses.reshape(k), params, grad_outputs=eye, is_grads_batched=True, retain_graph=True,
            allow_unused=True,
        )
    except RuntimeError as err:  # an op without a vmap rule in the backward graph
        if not _BATCHED_FALLBACK_WARNED:
            warnings.warn(
                f"batched per-task backward (is_grads_batched=True) is not possible for this loss ({err}); using "
                f"{k} separate backward passes",
                RuntimeWarning,
                stacklevel=3,
            )
            _BATCHED_FALLBACK_WARNED = True
        return None
    rows = [
        torch.zeros(k, p.numel(), dtype=p.dtype, device=p.device) if g is None else g.reshape(k, -1)
        for p, g in zip(params, grads)
    ]
    return torch.cat(rows, dim=1)


def per_task_gradients(
    task_losses: torch.Tensor,
    params: Sequence[torch.Tensor],
    *,
    retain_graph: bool = True,
    batched: bool = True,
) -> torch.Tensor:
    """Gradients of each of the ``K`` entries of ``task_losses`` w.r.t. ``params``, as a ``[K, P]`` matrix.

    One batched backward pass (:func:`batched_per_task_gradients`); where that is not possible, or with
    ``batched=False``, ``K`` separate backward passes (same result, slower). Rows of tasks that do not reach a
    parameter are zero.
    """
    params = list(params)
    k = task_losses.numel()
    if batched:
        grads = batched_per_task_gradients(task_losses, params)
        if grads is not None:
            return grads
    out = task_losses.new_zeros(k, sum(p.numel() for p in params))
    if not task_losses.requires_grad:
        return out
    task_losses = task_losses.reshape(k)
    for i in range(k):
        keep = retain_graph or i < k - 1
        out[i] = flatten(grads_or_zeros(task_losses[i], params, retain_graph=keep))
    return out


def flatten(tensors: Sequence[torch.Tensor]) -> torch.Tensor:
    """Concatenate tensors into one flat vector."""
    return torch.cat([t.reshape(-1) for t in tensors])


def unflatten(vector: torch.Tensor, like: Sequence[torch.Tensor]) -> list[torch.Tensor]:
    """Split a flat vector back into tensors shaped like ``like`` (inverse of :func:`flatten`)."""
    out, start = [], 0
    for t in like:
        n = t.numel()
        out.append(vector[start : start + n].view_as(t))
        start += n
    if start != vector.numel():
        raise ValueError(f"vector has {vector.numel()} entries, the tensors {start}")
    return out


def gram(grads: torch.Tensor) -> torch.Tensor:
    """``G G^T`` of a ``[K, P]`` gradient matrix."""
    return grads @ grads.T


def cosine_matrix(gram_matrix: torch.Tensor) -> torch.Tensor:
    """Pairwise cosine similarities from a Gram matrix (0 where a gradient is zero)."""
    norms = torch.diagonal(gram_matrix).clamp_min(0).sqrt()
    denom = norms[:, None] * norms[None, :]
    return torch.where(denom > 0, gram_matrix / denom.clamp_min(torch.finfo(denom.dtype).tiny), 0.0)


def cosine_stats(gram_matrix: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
    """``[mean, min, max]`` of the cosine similarity over pairs ``i < j`` of present tasks (NaN if < 2).

    Sync-free: the pair mask is applied with ``where``; no ``nonzero``/``.item()``.
    """
    k = gram_matrix.shape[0]
    cos = cosine_matrix(gram_matrix)
    upper = torch.ones(k, k, dtype=torch.bool, device=cos.device).triu(1)
    pairs = upper & present[:, None] & present[None, :]
    n = pairs.sum()
    nan = torch.full((), float("nan"), dtype=cos.dtype, device=cos.device)
    mean = torch.where(n > 0, torch.where(pairs, cos, 0.0).sum() / n.clamp_min(1), nan)
    lo = torch.where(n > 0, torch.where(pairs, cos, float("inf")).amin(), nan)
    hi = torch.where(n > 0, torch.where(pairs, cos, float("-inf")).amax(), nan)
    return torch.stack([mean, lo, hi])
