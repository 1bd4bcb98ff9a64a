"""LayerNorm residual MLP (MTBench's PQN Q network, after ACME's ``LayerNormAndResidualMLP``)."""

from __future__ import annotations

import math

import torch
from torch import nn

from .mlp import activation_class


def _orthogonal(layer: nn.Linear) -> nn.Linear:
    """MTBench's PQN initialisation: orthogonal weights with gain sqrt(2), zero bias."""
    nn.init.orthogonal_(layer.weight, math.sqrt(2.0))
    nn.init.zeros_(layer.bias)
    return layer


class ResidualBlock(nn.Module):
    """``LayerNorm(x + Linear(LayerNorm(act(Linear(x)))))`` (MTBench ``pq_network.Block``, 2 layers)."""

    def __init__(self, width: int, activation: str = "elu") -> None:
        super().__init__()
        self.layers = nn.Sequential(
            _orthogonal(nn.Linear(width, width)),
            activation_class(activation)(),
            nn.LayerNorm(width),
            _orthogonal(nn.Linear(width, width)),
        )
        self.norm = nn.LayerNorm(width)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.norm(x + self.layers(x))


class ResidualMLP(nn.Module):
    """``Linear -> act -> LayerNorm``, ``num_blocks - 1`` residual blocks, ``act -> Linear`` head, on the full
    observation (state + one-hot task id).

    MTBench's ``pq_network.QNetwork`` (``meta-world-mt-PQ.yaml``: ``num_blocks: 2``, ``D: 256``; its config says
    ``activation: relu`` but the network hard-codes ELU, which is what ran). Every ``Linear`` is initialised
    orthogonally with gain sqrt(2) and zero bias, as there.

    Args:
        obs_dim, out_dim, num_tasks: see :func:`~mtbench.modules.make_network`.
        hidden_dim: width D (256).
        num_blocks: MTBench's ``num_blocks`` (2 = the projection layer and one residual block).
        activation: ``elu`` (MTBench), ``relu``, ...
    """

    def __init__(
        self,
        obs_dim: int,
        out_dim: int,
        num_tasks: int,
        hidden_dim: int = 256,
        num_blocks: int = 2,
        activation: str = "elu",
    ) -> None:
        super().__init__()
        if not (isinstance(hidden_dim, int) and hidden_dim >= 1):
            raise ValueError(f"residual_mlp: hidden_dim must be an integer >= 1; got {hidden_dim!r}")
        if not (isinstance(num_blocks, int) and num_blocks >= 1):
            raise ValueError(f"residual_mlp: num_blocks must be an integer >= 1 (1 = no residual block); got "
                             f"{num_blocks!r}")
        act = activation_class(activation)
        self.num_tasks = num_tasks
        self.input = nn.Sequential(_orthogonal(nn.Linear(obs_dim, hidden_dim)), act(), nn.LayerNorm(hidden_dim))
        self.blocks = nn.Sequential(*[ResidualBlock(hidden_dim, activation) for _ in range(num_blocks - 1)])
        self.head = nn.Sequential(act(), _orthogonal(nn.Linear(hidden_dim, out_dim)))

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor | None = None) -> torch.Tensor:
        return self.head(self.blocks(self.input(observation)))


__all__ = ["ResidualBlock", "ResidualMLP"]
