"""Plain multi-layer perceptron conditioned on the one-hot task id inside the observation."""

from __future__ import annotations

from typing import Sequence

import torch
from torch import nn

_ACTIVATIONS: dict[str, type[nn.Module]] = {
    "elu": nn.ELU,
    "relu": nn.ReLU,
    "tanh": nn.Tanh,
    "gelu": nn.GELU,
    "silu": nn.SiLU,
}


def activation_class(name: str) -> type[nn.Module]:
    """Return the activation class for ``name`` (``elu``, ``relu``, ``tanh``, ``gelu``, ``silu``)."""
    try:
        return _ACTIVATIONS[name.lower()]
    except KeyError:
        raise ValueError(f"unknown activation {name!r}; valid choices: {sorted(_ACTIVATIONS)}") from None


def mlp_layers(in_dim: int, hidden: Sequence[int], activation: str = "elu") -> tuple[nn.Sequential, int]:
    """Build ``Linear -> act`` blocks for ``hidden`` sizes; returns the stack and its output width."""
    act = activation_class(activation)
    layers: list[nn.Module] = []
    width = in_dim
    for h in hidden:
        layers += [nn.Linear(width, h), act()]
        width = h
    return nn.Sequential(*layers), width


class MLP(nn.Module):
    """Vanilla single-head MLP on the full observation (state + one-hot task id).

    This is MTBench's "vanilla" architecture: the task is only known through the one-hot part of the input.
    """

    def __init__(
        self,
        obs_dim: int,
        out_dim: int,
        num_tasks: int,
        hidden: Sequence[int] = (256, 128, 64),
        activation: str = "elu",
    ) -> None:
        super().__init__()
        self.num_tasks = num_tasks
        self.trunk, width = mlp_layers(obs_dim, hidden, activation)
        self.head = nn.Linear(width, out_dim)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor | None = None) -> torch.Tensor:
        return self.head(self.trunk(observation))
