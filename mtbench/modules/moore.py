"""MOORE (Hendawy et al., 2024): mixture of orthogonal experts weighted by a task encoder."""

from __future__ import annotations

from typing import Sequence

import torch
from torch import nn

from .experts import ParallelExperts, mix_experts
from .gram_schmidt import gram_schmidt, gram_schmidt_coefficients
from .inputs import check_sizes, flatten_inputs, unflatten_output
from .mlp import activation_class
from .stacked_linear import StackedLinear
from .task_rows import task_rows


def _maybe_activation(name: str) -> nn.Module:
    if name.lower() in ("linear", "identity", "none"):
        return nn.Identity()
    try:
        return activation_class(name)()
    except ValueError:
        raise ValueError(f"moore: unknown agg_activation {name!r}; valid choices: linear, elu, relu, tanh, gelu, silu") from None


class MOORE(nn.Module):
    """Mixture Of ORthogonal Experts; ``multi_head=False`` is MTBench's SH-MOORE, ``True`` MH-MOORE.

    * ``num_experts`` experts (default 4 = MT10; the paper uses 6 for MT50), each an MLP of ``num_layers`` linear
      layers of width ``hidden_dim`` (400) with ReLU between and a linear last layer, on the state (one-hot removed).
    * Per-sample Gram-Schmidt across the experts (:func:`gram_schmidt`), giving orthonormal ``U [E, D]`` for each
      sample, computed as ``U = C H`` from the ``E x E`` Gram matrix of the expert outputs
      (:func:`gram_schmidt_coefficients`); with a linear ``agg_activation[0]`` (the default) ``U`` is never built:
      ``sum_e w_e u_e = sum_e (w^T C)_e h_e``. Unlike the originals, the norm carries an ``eps`` (``gs_eps``, relative to the expert output's norm,
      default 1e-4) so zero or (numerically) dependent expert outputs give finite, damped vectors instead of NaN.
    * Task weights ``w = MLP(one-hot)``: hidden ``task_encoder`` ([256]) ReLU, then ``Linear(., E)``; no biases
      (``task_encoder_bias=False``), no normalisation of ``w`` (as in MOORE/MTBench).
    * ``v = act1(sum_e w_e act0(U_e))`` with ``agg_activation = (act0, act1)``, default ``("linear", "tanh")``
      (paper's Meta-World setting; Parkour uses ``("linear", "linear")``).
    * Head: SH = ``Linear(concat(v, one-hot))`` (MTBench), MH = one ``Linear(D, out)`` per task, gathered by task id
      (original MOORE and MTBench's MH-MOORE).

    Initialisation: per-expert Xavier (ReLU gain on hidden layers, gain 1 on the last) with zero biases (MTBench's
    ``U[0,1)`` MoE biases are not reproduced), Xavier for the task encoder and heads, zero head biases.
    The task encoder is evaluated on the ``num_tasks`` one-hots and gathered by ``task_id``.
    """

    def __init__(
        self,
        obs_dim: int,
        out_dim: int,
        num_tasks: int,
        num_experts: int = 4,
        num_layers: int = 3,
        hidden_dim: int = 400,
        task_encoder: Sequence[int] = (256,),
        task_encoder_bias: bool = False,
        agg_activation: Sequence[str] = ("linear", "tanh"),
        multi_head: bool = False,
        gs_eps: float = 1e-4,
    ) -> None:
        super().__init__()
        state_dim = check_sizes("moore", obs_dim, out_dim, num_tasks)
        if not 1 <= num_experts <= hidden_dim:
            raise ValueError(f"moore: need 1 <= num_experts <= hidden_dim for Gram-Schmidt, got {num_experts}, {hidden_dim}")
        if len(agg_activation) != 2:
            raise ValueError(f"moore: agg_activation must be two names (before, after weighting), got {agg_activation!r}")
        if gs_eps <= 0:
            raise ValueError(f"moore: gs_eps must be > 0, got {gs_eps}")
        self.obs_dim = obs_dim
        self.num_tasks = num_tasks
        self.multi_head = multi_head
        self.gs_eps = float(gs_eps)
        self.experts = ParallelExperts(num_experts, state_dim, hidden_dim, hidden_dim, num_layers)
        self.pre_activation = _maybe_activation(agg_activation[0])
        self.post_activation = _maybe_activation(agg_activation[1])

        relu_gain = nn.init.calculate_gain("relu")
        enc: list[nn.Module] = []
        width = num_tasks
        for units in task_encoder:
            lin = nn.Linear(width, units, bias=task_encoder_bias)
            nn.init.xavier_uniform_(lin.weight, gain=relu_gain)
            enc += [lin, nn.ReLU()]
            width = units
        last = nn.Linear(width, num_experts, bias=task_encoder_bias)
        nn.init.xavier_uniform_(last.weight)
        self.task_encoder = nn.Sequential(*enc, last)
        for m in self.task_encoder.modules():
            if isinstance(m, nn.Linear) and m.bias is not None:
                nn.init.zeros_(m.bias)

        if multi_head:
            self.heads: StackedLinear | nn.Linear = StackedLinear(num_tasks, hidden_dim, out_dim).xavier_(1.0)
        else:
            self.heads = nn.Linear(hidden_dim + num_tasks, out_dim)
            nn.init.xavier_uniform_(self.heads.weight)
            nn.init.zeros_(self.heads.bias)
        self.register_buffer("task_onehots", torch.eye(num_tasks), persistent=False)

    def task_weights(self) -> torch.Tensor:
        """Expert weights of every task, ``[num_tasks, num_experts]``."""
        return self.task_encoder(self.task_onehots)

    def orthogonal_representations(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        """Gram-Schmidt expert outputs ``[num_experts, *batch, hidden_dim]`` (orthonormal across experts)."""
        obs, _, batch_shape = flatten_inputs(observation, task_id, self.obs_dim, "moore")
        u = gram_schmidt(self.experts(obs[:, : -self.num_tasks]), self.gs_eps)
        return u.reshape(u.shape[0], *batch_shape, u.shape[-1])

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        obs, tid, batch_shape = flatten_inputs(observation, task_id, self.obs_dim, "moore")
        h = self.experts(obs[:, : -self.num_tasks])  # [E, B, D]
        w = task_rows(self.task_weights(), tid)  # [B, E]
        if isinstance(self.pre_activation, nn.Identity):
            # sum_e w_e u_e = sum_e (w^T C)_e h_e with u = C h: the orthonormal basis is never materialised
            coef = (w.to(torch.float64).unsqueeze(-1) * gram_schmidt_coefficients(h, self.gs_eps)).sum(1)  # w^T C
            mixed = mix_experts(coef.to(h.dtype), h)
        else:
            mixed = mix_experts(w, self.pre_activation(gram_schmidt(h, self.gs_eps)))
        v = self.post_activation(mixed)
        if self.multi_head:
            out = self.heads.forward_selected(v, tid)
        else:
            out = self.heads(torch.cat([v, obs[:, -self.num_tasks :]], dim=-1))
        return unflatten_output(out, batch_shape)
