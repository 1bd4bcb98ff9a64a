"""CAGrad (Liu et al. 2021, "Conflict-Averse Gradient Descent") with an on-device dual solver."""

from __future__ import annotations

from typing import Any

import torch
from torchrl.objectives import LossModule

from .task_wrapper import TaskGradientWrapper

CAGRAD_RESCALES = (0, 1, 2)


def project_simplex(v: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
    """Euclidean projection of each row of ``v [..., K]`` onto ``{w >= 0, sum w = 1, w_k = 0 if not present}``.

    Sort-based (Duchi et al. 2008), batched, no host sync.
    """
    k = v.shape[-1]
    pres = present.expand_as(v)
    u, idx = torch.sort(torch.where(pres, v, float("-inf")), dim=-1, descending=True)
    pres_sorted = pres.gather(-1, idx)
    u = torch.where(pres_sorted, u, 0.0)
    css = u.cumsum(-1)
    ranks = torch.arange(1, k + 1, dtype=v.dtype, device=v.device)
    support = ((u - (css - 1) / ranks) > 0) & pres_sorted  # true on a prefix of the sorted entries
    r = support.sum(-1, keepdim=True).clamp_min(1)
    theta = (css.gather(-1, r - 1) - 1) / r.to(v.dtype)
    return torch.where(pres, (v - theta).clamp_min(0), 0.0)


def cagrad_objective(w: torch.Tensor, a: torch.Tensor, b: torch.Tensor, rho: torch.Tensor) -> torch.Tensor:
    """``w.b + rho sqrt(w^T A w)`` for each row of ``w [..., K]`` (``b = A u0``: ``g_w.g_0``)."""
    q = ((w @ a) * w).sum(-1).clamp_min(0)
    return w @ b + rho * q.sqrt()


def cagrad_weights(
    gram_matrix: torch.Tensor,
    present: torch.Tensor | None = None,
    c: float = 0.4,
    *,
    iters: int = 20,
    line_search: int = 8,
) -> torch.Tensor:
    """Solve CAGrad's dual ``min_{w in simplex} g_w.g_0 + c ||g_0|| ||g_w||`` on the device; returns ``w [K]``.

    ``g_w = sum_k w_k g_k``, ``g_0`` = mean of the present task gradients, everything through the Gram
    matrix ``A = G G^T``; absent tasks are held at ``w_k = 0``. The problem is solved in float64 (it is
    tiny, and first-order methods stall in float32 on the ill-conditioned Gram matrices of correlated task
    gradients) by ``iters`` monotone iterations, each choosing the best of three candidates evaluated in
    parallel: the current point, a projected-gradient step of the majorise-minimise bound
    ``sqrt(x) <= (x / t + t) / 2`` (step ``||g_w|| / (rho L)``, ``L = ||P A P||_F`` on the simplex's tangent
    space -- always a descent step), and a projected Newton step on the current support (KKT system solved
    with ``torch.linalg.solve_ex``, no error check, hence no sync) with ``line_search`` step sizes
    ``1, 1/2, ...``. Fixed iteration count, batched tensor ops only: no ``.item()``, no host round trip.
    Scale-invariant (``A`` is normalised by its largest diagonal entry).
    """
    k = gram_matrix.shape[0]
    dt = torch.float64
    dev = gram_matrix.device
    if present is None:
        present = torch.ones(k, dtype=torch.bool, device=dev)
    a = gram_matrix.to(dt)
    pf = present.to(dt)
    n = pf.sum().clamp_min(1.0)
    u0 = pf / n
    tiny = torch.finfo(dt).tiny
    diag = torch.where(present, torch.diagonal(a), 0.0)
    a = a / diag.amax().clamp_min(tiny)
    a = a * pf[:, None] * pf[None, :]
    b = a @ u0
    rho = c * (u0 @ b).clamp_min(0).sqrt()
    proj = torch.diag(pf) - pf[:, None] * pf[None, :] / n
    lip = torch.linalg.matrix_norm(proj @ a @ proj)  # Frobenius >= spectral norm on the tangent space
    steps = 2.0 ** -torch.arange(line_search, dtype=dt, device=dev)
    reg = 1e-10 * torch.eye(k, dtype=dt, device=dev)
    w = u0
    for _ in range(iters):
        aw = a @ w
        q = (w @ aw).clamp_min(tiny).sqrt()
        grad = b + rho * aw / q
        # Newton direction on the support {w_k > 0}: [H 1; 1^T 0] [d; mu] = [-grad; 0]
        free = (present & (w > 1e-9)).to(dt)
        hess = (rho / q) * (a - aw[:, None] * aw[None, :] / (q * q))
        kkt = torch.nn.functional.pad(hess * free[:, None] * free[None, :] + torch.diag(1.0 - free) + reg, (0, 1, 0, 1))
        kkt[:k, k] = free
        kkt[k, :k] = free
        sol, _ = torch.linalg.solve_ex(kkt, torch.nn.functional.pad(-grad * free, (0, 1)))
        delta = torch.nan_to_num(sol[:k] * free, nan=0.0, posinf=0.0, neginf=0.0)
        # candidates: majorise-minimise projected-gradient step, Newton steps of decreasing length
        raw = torch.cat([(w - (q / (rho * lip).clamp_min(tiny)) * grad)[None], w + steps[:, None] * delta], 0)
        cands = torch.cat([w[None], project_simplex(raw, present)], 0)
        values = torch.nan_to_num(cagrad_objective(cands, a, b, rho), nan=float("inf"))
        w = cands.index_select(0, values.argmin().reshape(1)).squeeze(0)  # no tensor->int conversion
    return w


def cagrad(
    grads: torch.Tensor,
    present: torch.Tensor | None = None,
    c: float = 0.4,
    *,
    rescale: int = 1,
    iters: int = 20,
    gram_matrix: torch.Tensor | None = None,
) -> torch.Tensor:
    """CAGrad update ``[P]`` from per-task gradients ``grads [K, P]``.

    ``d = g_0 + c ||g_0|| g_w / ||g_w||`` with ``w`` from :func:`cagrad_weights`; ``rescale`` 1 (default,
    MTBench/LibMTL) returns ``d / (1 + c^2)``, 2 ``d / (1 + c)``, 0 ``d``. ``c = 0`` gives ``g_0`` exactly.
    """
    if rescale not in CAGRAD_RESCALES:
        raise ValueError(f"unknown CAGrad rescale {rescale!r}; valid choices: {list(CAGRAD_RESCALES)}")
    if c < 0:
        raise ValueError(f"CAGrad c must be >= 0, got {c}")
    k = grads.shape[0]
    if present is None:
        present = torch.ones(k, dtype=torch.bool, device=grads.device)
    pf = present.to(grads.dtype)
    g0 = (pf / pf.sum().clamp_min(1.0)) @ grads
    if c == 0:
        return g0
    if gram_matrix is None:
        gram_matrix = grads @ grads.T
    w = cagrad_weights(gram_matrix, present, c, iters=iters).to(grads.dtype)
    gw = w @ grads
    tiny = torch.finfo(grads.dtype).tiny
    d = g0 + (c * torch.linalg.vector_norm(g0) / torch.linalg.vector_norm(gw).clamp_min(tiny)) * gw
    if rescale == 1:
        d = d / (1.0 + c * c)
    elif rescale == 2:
        d = d / (1.0 + c)
    return d


class CAGrad(TaskGradientWrapper):
    """Conflict-averse gradient descent on a parameter group of a TorchRL loss.

    Args:
        loss_module, num_tasks, params, diagnostics_every, critic_keys, task_loss_scale:
            see :class:`~mtbench.objectives.task_wrapper.TaskGradientWrapper`.
        c: radius of the ball around the mean gradient (MTBench: 0.4).
        rescale: 1 -> ``d / (1 + c^2)`` (MTBench, default), 2 -> ``d / (1 + c)``, 0 -> ``d``.
        scale_by_num_tasks: multiply the update by the number of tasks present in the minibatch. MTBench's
            ``overwrite_grad`` does this ("to match the sum loss"), so the default is ``True`` to reproduce
            the paper's effective step (it matters with global grad-norm clipping at 1.0; with Adam alone it
            only changes the update through ``eps``). ``False`` keeps the mean-gradient scale (``c = 0``
            then gives exactly the plain mean of the per-task gradients).
        solver_iters: iterations of the on-device dual solver (:func:`cagrad_weights`).

    Cost: K backward passes through the group in one batched call, an ``O(K^2 P)`` Gram matrix and a
    ``K``-dimensional solve on the device (no GPU->CPU sync, unlike MTBench's scipy SLSQP).
    """

    def __init__(
        self,
        loss_module: LossModule,
        num_tasks: int,
        *,
        c: float = 0.4,
        rescale: int = 1,
        scale_by_num_tasks: bool = True,
        solver_iters: int = 20,
        **kwargs: Any,
    ) -> None:
        if rescale not in CAGRAD_RESCALES:
            raise ValueError(f"unknown CAGrad rescale {rescale!r}; valid choices: {list(CAGRAD_RESCALES)}")
        if c < 0:
            raise ValueError(f"CAGrad c must be >= 0, got {c}")
        if int(solver_iters) < 1:
            raise ValueError(f"solver_iters must be >= 1, got {solver_iters}")
        super().__init__(loss_module, num_tasks, **kwargs)
        self.c = float(c)
        self.rescale = int(rescale)
        self.scale_by_num_tasks = bool(scale_by_num_tasks)
        self.solver_iters = int(solver_iters)

    def _combine(self, grads: torch.Tensor, gram_matrix: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
        d = cagrad(grads, present, self.c, rescale=self.rescale, iters=self.solver_iters, gram_matrix=gram_matrix)
        if self.scale_by_num_tasks:
            d = d * present.sum().to(d.dtype)
        return d
