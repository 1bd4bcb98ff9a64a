"""PCGrad (Yu et al. 2020, "Gradient Surgery for Multi-Task Learning") as a loss-module wrapper."""

from __future__ import annotations

from typing import Any

import torch
from torchrl.objectives import LossModule

from .task_wrapper import TaskGradientWrapper

PCGRAD_REDUCTIONS = ("mean", "sum")


def random_task_orders(num_tasks: int, generator: torch.Generator, device: torch.device | str) -> torch.Tensor:
    """One random permutation of the task indices per task: ``[K, K]`` (row ``i`` = order for task ``i``)."""
    keys = torch.rand(num_tasks, num_tasks, generator=generator, device=device)
    return keys.argsort(dim=1)


def pcgrad_weights(
    gram_matrix: torch.Tensor,
    present: torch.Tensor,
    orders: torch.Tensor,
    reduction: str = "mean",
) -> torch.Tensor:
    """PCGrad as coefficients on the task gradients: returns ``lam [K]`` with ``update = lam @ G``.

    For every task ``i`` (all at once), ``g_i^PC <- g_i``; then for ``j`` in ``orders[i]`` (``j != i``,
    ``j`` present): if ``g_i^PC . g_j < 0``: ``g_i^PC <- g_i^PC - (g_i^PC . g_j) / ||g_j||^2 g_j``
    (running ``g_i^PC``, *original* ``g_j``). Each ``g_i^PC`` stays a combination ``C_i @ G`` of the original
    gradients, so the whole procedure runs on the ``K x K`` Gram matrix ``G G^T`` (``O(K^3)``, no ``[K, P]``
    temporaries); the loop is over the K positions of the orders, vectorised over tasks. The result is
    ``mean`` (MTBench, mtrl) or ``sum`` (paper, LibMTL) of ``g_i^PC`` over the present tasks.
    """
    if reduction not in PCGRAD_REDUCTIONS:
        raise ValueError(f"unknown PCGrad reduction {reduction!r}; valid choices: {list(PCGRAD_REDUCTIONS)}")
    k = gram_matrix.shape[0]
    a = gram_matrix
    coef = torch.eye(k, dtype=a.dtype, device=a.device)  # g_i^PC = coef[i] @ G
    rows = torch.arange(k, device=a.device)
    sq_norms = torch.diagonal(a)
    for s in range(k):
        j = orders[:, s]  # [K]: the task each i projects against at this step
        dots = (coef * a[j]).sum(1)  # g_i^PC . g_j  (a symmetric: a[j][i, l] = g_l . g_{j_i})
        conflict = (dots < 0) & present[j] & (j != rows)
        step = torch.where(conflict, dots / sq_norms[j].clamp_min(torch.finfo(a.dtype).tiny), 0.0)
        coef = coef.scatter_add(1, j[:, None], -step[:, None])
    keep = present.to(a.dtype)
    if reduction == "mean":
        keep = keep / keep.sum().clamp_min(1.0)
    return keep @ coef


def pcgrad(
    grads: torch.Tensor,
    present: torch.Tensor | None = None,
    *,
    orders: torch.Tensor | None = None,
    generator: torch.Generator | None = None,
    reduction: str = "mean",
) -> torch.Tensor:
    """PCGrad update ``[P]`` from per-task gradients ``grads [K, P]`` (rows of absent tasks are ignored).

    ``orders`` fixes the projection orders (``[K, K]``); otherwise they are drawn with ``generator``.
    """
    k = grads.shape[0]
    if present is None:
        present = torch.ones(k, dtype=torch.bool, device=grads.device)
    if orders is None:
        if generator is None:
            orders = torch.rand(k, k, device=grads.device).argsort(dim=1)
        else:
            orders = random_task_orders(k, generator, grads.device)
    lam = pcgrad_weights(grads @ grads.T, present, orders, reduction)
    return lam.to(grads.dtype) @ grads


class PCGrad(TaskGradientWrapper):
    """Projecting conflicting per-task gradients (PCGrad) on a parameter group of a TorchRL loss.

    ``PCGrad(ClipPPOLoss(actor, critic), num_tasks=10)`` manipulates the per-task critic gradients (MTBench's
    PPO configs); the actor terms get their plain batch-mean gradient. Task orders are random per update,
    drawn from a ``torch.Generator`` on the gradients' device seeded with ``seed`` (its state is saved in
    the ``state_dict``). Cost: K backward passes through the group in one batched call, an ``O(K^2 P)``
    Gram matrix, ``O(K^3)`` projections.

    Args:
        loss_module, num_tasks, params, diagnostics_every, critic_keys, task_loss_scale:
            see :class:`~mtbench.objectives.task_wrapper.TaskGradientWrapper`.
        reduction: ``"mean"`` of the projected gradients (MTBench, default) or ``"sum"`` (paper).
        seed: seed of the task-order generator.
    """

    def __init__(
        self,
        loss_module: LossModule,
        num_tasks: int,
        *,
        reduction: str = "mean",
        seed: int = 0,
        **kwargs: Any,
    ) -> None:
        if reduction not in PCGRAD_REDUCTIONS:
            raise ValueError(f"unknown PCGrad reduction {reduction!r}; valid choices: {list(PCGRAD_REDUCTIONS)}")
        super().__init__(loss_module, num_tasks, **kwargs)
        self.pcgrad_reduction = reduction
        self.seed = int(seed)
        self._generator: torch.Generator | None = None
        self._pending_state: torch.Tensor | None = None

    def _get_generator(self, device: torch.device) -> torch.Generator:
        if self._generator is None or self._generator.device != device:
            if device.type == "cuda" and torch.cuda.is_current_stream_capturing():
                raise RuntimeError(
                    "PCGrad: the task-order generator must exist before CUDA-graph capture (run one eager update "
                    "first, or load the checkpoint before capturing) so that it can be registered with the graph"
                )
            gen = torch.Generator(device=device)
            gen.manual_seed(self.seed)
            if self._pending_state is not None:
                try:
                    gen.set_state(self._pending_state)
                except RuntimeError:  # state from another device type: keep the seeded generator
                    pass
                self._pending_state = None
            self._generator = gen
        return self._generator

    def _combine(self, grads: torch.Tensor, gram_matrix: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
        orders = random_task_orders(self.num_tasks, self._get_generator(grads.device), grads.device)
        lam = pcgrad_weights(gram_matrix, present, orders, self.pcgrad_reduction)
        return lam @ grads

    def cuda_graph_generators(self) -> list[torch.Generator]:
        """The task-order generator (once created by an update), registered with a captured graph so that every
        replay draws new orders."""
        return [] if self._generator is None else [self._generator]

    def get_extra_state(self) -> dict[str, Any]:
        state = self._generator.get_state() if self._generator is not None else self._pending_state
        return {**super().get_extra_state(), "seed": self.seed, "generator_state": state}

    def set_extra_state(self, state: dict[str, Any]) -> None:
        super().set_extra_state(state)
        self.seed = int(state.get("seed", self.seed))
        self._generator = None
        self._pending_state = state.get("generator_state")
        if self._pending_state is not None:
            # create the generator now, on the parameters' device, so that a CUDA graph captured after loading
            # (the trainer re-captures without eager warm-up) can register it
            self._get_generator(next(iter(self.loss_module.parameters())).device)
