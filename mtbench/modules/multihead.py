"""Multi-head MLP: a shared trunk and one linear output head per task (MTBench's ``MH`` baseline)."""

from __future__ import annotations

from typing import Sequence

import torch
from torch import nn

from .inputs import check_sizes, flatten_inputs, unflatten_output
from .mlp import mlp_layers
from .stacked_linear import StackedLinear


class MultiHeadMLP(nn.Module):
    """Shared trunk MLP on the full observation (state + one-hot) and one ``Linear`` head per task.

    Defaults follow MTBench's ``meta-world-mt10-vanilla-MHPPO`` (trunk ``[256, 128, 64]`` ELU, PyTorch default
    initialisation). The ``num_tasks`` heads live in one ``[num_tasks, width, out_dim]`` weight tensor; the output of
    sample ``i`` is ``head_{task_id[i]}(trunk(observation_i))``, computed by one matmul and a gather (no Python loop
    over tasks). Task ``k``'s loss therefore produces exactly zero gradient on every other task's head.
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
        check_sizes("multihead", obs_dim, out_dim, num_tasks)
        self.obs_dim = obs_dim
        self.num_tasks = num_tasks
        self.trunk, width = mlp_layers(obs_dim, hidden, activation)
        self.heads = StackedLinear(num_tasks, width, out_dim)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        obs, tid, batch_shape = flatten_inputs(observation, task_id, self.obs_dim, "multihead")
        return unflatten_output(self.heads.forward_selected(self.trunk(obs), tid), batch_shape)
