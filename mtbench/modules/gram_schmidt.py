"""Per-sample Gram-Schmidt orthonormalisation across experts (MOORE's ``OrthogonalLayer1D``), NaN-safe, computed
through the per-sample ``E x E`` Gram matrix."""

from __future__ import annotations

import torch


class _Gram(torch.autograd.Function):
    """``A[n, i, j] = h_i . h_j`` (float64) for ``h [E, N, D]``; the backward is the one matmul ``(dA + dA^T) H`` in
    ``h``'s own dtype (autograd of the einsum would run two, one per operand, and add them, in float64): only the
    forward needs float64, for ``|r_i|^2`` (a GPU profile put MOORE's float64 Gram backward at 1.3 ms of an 11 ms
    update, docs/benchmarks.md §9)."""

    generate_vmap_rule = True

    @staticmethod
    def forward(h: torch.Tensor) -> torch.Tensor:
        h64 = h.to(torch.float64)
        return torch.einsum("ind,jnd->nij", h64, h64)

    @staticmethod
    def setup_context(ctx, inputs, output) -> None:
        ctx.save_for_backward(inputs[0])

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> torch.Tensor:
        (h,) = ctx.saved_tensors
        # matmul, not einsum: the batched per-task backward (is_grads_batched) vmaps this, einsum has no rule there
        sym = (grad + grad.transpose(-1, -2)).to(h.dtype)
        return torch.matmul(sym, h.transpose(0, 1)).transpose(0, 1)


def gram_schmidt_coefficients(h: torch.Tensor, eps: float = 1e-4, eps_abs: float = 1e-6) -> torch.Tensor:
    """Lower-triangular ``C [N, E, E]`` (float64) with ``u_i = sum_j C[n, i, j] h_j`` for ``h [E, N, D]``.

    The Gram-Schmidt recursion of :func:`gram_schmidt` written on the per-sample Gram matrix ``A = H H^T``
    (``A[n, i, j] = h_i . h_j``, one batched float64 matmul): with ``u_j = C_j H``, the projections are
    ``h_i . u_j = (C A)[j, i]``, the residual ``r_i = R_i H`` with ``R_i = e_i - sum_{j<i} (h_i . u_j) C_j`` and
    ``|r_i|^2 = R_i A R_i^T``. Only ``[N, E, E]`` tensors enter the recursion, so the ``[E, N, D]`` expert
    outputs are read twice (Gram matrix, combination) instead of once per projection; float64 keeps
    ``|r_i|^2`` accurate where it is small against ``|h_i|^2`` (nearly dependent experts).
    """
    return coefficients_from_gram(_Gram.apply(h), eps, eps_abs)


def coefficients_from_gram(a: torch.Tensor, eps: float = 1e-4, eps_abs: float = 1e-6) -> torch.Tensor:
    """The Gram-Schmidt coefficients ``C [N, E, E]`` of :func:`gram_schmidt_coefficients` from the per-sample Gram
    matrix ``a [N, E, E]`` (``a[n, i, j] = h_i . h_j``, float64), however it was computed."""
    e = a.shape[-1]
    diag = torch.diagonal(a, dim1=-2, dim2=-1)  # |h_i|^2, [N, E]
    eye = torch.eye(e, dtype=a.dtype, device=a.device)
    rows: list[torch.Tensor] = []
    for i in range(e):
        r = eye[i].expand(a.shape[0], e)
        # element-wise products and sums, not einsum: on [N, <=E, E] tensors a batched GEMM wastes its tiles
        # (a GPU profile put these float64 GEMMs at 1.15 ms of MOORE's 11 ms update, docs/benchmarks.md §9)
        if rows:
            prev = torch.stack(rows, dim=1)  # [N, i, E]: u_j = prev[:, j] @ H
            proj = (prev * a[:, i].unsqueeze(1)).sum(-1)  # h_i . u_j, [N, i]
            r = r - (proj.unsqueeze(-1) * prev).sum(1)
        sq = ((r.unsqueeze(-1) * a).sum(1) * r).sum(-1).clamp_min(0.0)  # r A r^T
        sq = sq + (eps * eps) * diag[:, i] + eps_abs * eps_abs
        rows.append(r / sq.sqrt().unsqueeze(-1))
    return torch.stack(rows, dim=1)


def gram_schmidt(h: torch.Tensor, eps: float = 1e-4, eps_abs: float = 1e-6) -> torch.Tensor:
    """Orthonormalise ``h [E, ..., D]`` across its first (expert) dim, independently for every sample.

    ``u_1 = h_1 / |h_1|``, ``u_i = r_i / |r_i|`` with ``r_i = h_i - sum_{j<i} (h_i . u_j) u_j`` (classical
    Gram-Schmidt, as in MOORE/MTBench), so for each sample the ``E`` output vectors satisfy ``U U^T = I_E``
    (requires ``E <= D``). Computed as ``U = C H`` with the coefficients of :func:`gram_schmidt_coefficients`.

    NaN guard: the norm is replaced by ``sqrt(|r_i|^2 + eps^2 |h_i|^2 + eps_abs^2)``. The originals divide by
    ``|r_i|``, which gives NaN (forward and backward) as soon as an expert output is zero or linearly dependent on the
    previous ones (e.g. two identical experts, or an all-zero state with zero biases), and amplifies float round-off
    into a random unit direction with huge gradients when it is *numerically* dependent. With the guard a residual
    much smaller than ``eps * |h_i|`` maps to a vector of norm ``~|r_i| / (eps |h_i|)`` (exactly 0 for ``r_i = 0``),
    gradients stay bounded by ``~1 / (eps |h_i|)``, and the result stays invariant to rescaling an expert output.
    The price: unit norms shrink by a relative ``~eps^2 |h_i|^2 / (2 |r_i|^2)``, i.e. ~5e-9 for independent outputs
    (``|r_i| ~ |h_i|``) with the default ``eps = 1e-4``.
    """
    e, d = h.shape[0], h.shape[-1]
    flat = h.reshape(e, -1, d)
    coef = gram_schmidt_coefficients(flat, eps, eps_abs).to(h.dtype)  # [N, E, E]
    return torch.einsum("nij,jnd->ind", coef, flat).reshape(h.shape)


def gram_schmidt_vectors(h: torch.Tensor, eps: float = 1e-4, eps_abs: float = 1e-6) -> torch.Tensor:
    """The same guarded classical Gram-Schmidt as :func:`gram_schmidt`, computed on the vectors themselves (one
    projection per expert, the former implementation): the reference that tests and ``benchmarks/kernel_levers.py``
    compare the Gram-matrix form with. ``h [E, ..., D]``."""
    basis: list[torch.Tensor] = []
    for i in range(h.shape[0]):
        hi = h[i]
        r = hi
        if basis:
            u_prev = torch.stack(basis)
            r = hi - ((u_prev * hi.unsqueeze(0)).sum(-1, keepdim=True) * u_prev).sum(0)
        sq = (r * r).sum(-1, keepdim=True) + (eps * eps) * (hi * hi).sum(-1, keepdim=True) + eps_abs * eps_abs
        basis.append(r / torch.sqrt(sq))
    return torch.stack(basis)
