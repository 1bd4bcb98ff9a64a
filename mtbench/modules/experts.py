"""Mixture-of-experts feed-forward block: several same-shaped MLPs evaluated in one batched pass."""

from __future__ import annotations

import torch
from torch import nn

from .stacked_linear import StackedLinear


def mix_experts(weights: torch.Tensor, outputs: torch.Tensor) -> torch.Tensor:
    """Per-sample weighted sum of expert outputs: ``weights [B, E]``, ``outputs [E, B, D]`` -> ``[B, D]``.

    A broadcast product and a sum, not ``einsum("be,ebd->bd")``: that is a batched GEMM with inner dimension ``E``
    (forward) and ``1`` (its backward's outer products), which cuBLAS runs as GEMV and SIMT kernels far below the
    memory bandwidth (on an H200 such a PaCo layer took ~0.57 ms of kernels per update, docs/benchmarks.md §9)."""
    return (weights.t().unsqueeze(-1) * outputs).sum(0)


class ParallelExperts(nn.Module):
    """``num_experts`` MLPs with identical shapes evaluated in parallel on the same input.

    ``num_layers`` linear layers (``in -> hidden -> ... -> out``) with ``activation`` between them and a linear last
    layer; the output is ``[num_experts, B, out]``. Initialisation: per-expert Xavier-uniform (ReLU gain on hidden
    layers, linear gain on the last) with zero biases (mtrl's ``weight_init_moe_layer``; MTBench's 3-D xavier and
    ``U[0, 1)`` biases are not reproduced).
    """

    def __init__(
        self,
        num_experts: int,
        in_features: int,
        hidden_features: int,
        out_features: int,
        num_layers: int,
        activation: type[nn.Module] = nn.ReLU,
    ) -> None:
        super().__init__()
        if num_layers < 1:
            raise ValueError(f"ParallelExperts: num_layers must be >= 1, got {num_layers}")
        self.num_experts = num_experts
        relu_gain = nn.init.calculate_gain("relu")
        layers: list[StackedLinear] = []
        width = in_features
        for i in range(num_layers):
            last = i == num_layers - 1
            out = out_features if last else hidden_features
            layers.append(StackedLinear(num_experts, width, out).xavier_(1.0 if last else relu_gain))
            width = out
        self.layers = nn.ModuleList(layers)
        self.act = activation()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``x [B, in]`` -> ``[num_experts, B, out]``."""
        h = x
        for i, layer in enumerate(self.layers):
            h = layer(h)
            if i < len(self.layers) - 1:
                h = self.act(h)
        return h
