"""Per-sample Gram-Schmidt orthonormalisation across experts (MOORE's ``OrthogonalLayer1D``), NaN-safe."""

from __future__ import annotations

import torch


def gram_schmidt(h: torch.Tensor, eps: float = 1e-4, eps_abs: float = 1e-6) -> torch.Tensor:
    """Orthonormalise ``h [E, ..., D]`` across its first (expert) dim, independently for every sample.

    ``u_1 = h_1 / |h_1|``, ``u_i = r_i / |r_i|`` with ``r_i = h_i - sum_{j<i} (h_i . u_j) u_j`` (classical
    Gram-Schmidt, as in MOORE/MTBench), so for each sample the ``E`` output vectors satisfy ``U U^T = I_E``
    (requires ``E <= D``).

    NaN guard: the norm is replaced by ``sqrt(|r_i|^2 + eps^2 |h_i|^2 + eps_abs^2)``. The originals divide by
    ``|r_i|``, which gives NaN (forward and backward) as soon as an expert output is zero or linearly dependent on the
    previous ones (e.g. two identical experts, or an all-zero state with zero biases), and amplifies float round-off
    into a random unit direction with huge gradients when it is *numerically* dependent. With the guard a residual
    much smaller than ``eps * |h_i|`` maps to a vector of norm ``~|r_i| / (eps |h_i|)`` (exactly 0 for ``r_i = 0``),
    gradients stay bounded by ``~1 / (eps |h_i|)``, and the result stays invariant to rescaling an expert output.
    The price: unit norms shrink by a relative ``~eps^2 |h_i|^2 / (2 |r_i|^2)``, i.e. ~5e-9 for independent outputs
    (``|r_i| ~ |h_i|``) with the default ``eps = 1e-4``.
    """
    basis: list[torch.Tensor] = []
    for i in range(h.shape[0]):
        hi = h[i]
        r = hi
        if basis:
            u_prev = torch.stack(basis)  # [i, ..., D]
            coeff = (u_prev * hi.unsqueeze(0)).sum(-1, keepdim=True)  # [i, ..., 1]
            r = hi - (coeff * u_prev).sum(0)
        sq = (r * r).sum(-1, keepdim=True) + (eps * eps) * (hi * hi).sum(-1, keepdim=True) + eps_abs * eps_abs
        basis.append(r / torch.sqrt(sq))
    return torch.stack(basis)
