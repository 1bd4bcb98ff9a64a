"""PaCo (Sun et al., 2022): parameter-compositional multi-task network."""

from __future__ import annotations

import functools

import torch
from torch import nn

from .compositional_linear import CompositionalLinear
from .inputs import check_sizes, flatten_inputs, unflatten_output
from .mlp import activation_class
from .task_rows import task_rows


class PaCo(nn.Module):
    """Every layer holds ``K = num_sets`` parameter sets; task ``t`` uses ``theta_t = sum_k w_{t,k} phi_k``.

    Defaults follow MTBench's MT10 setup (the paper's): ``K = 5`` (MT50: 20), ``num_layers = 3`` compositional hidden
    layers of width ``hidden_dim = 400`` with ReLU, and a compositional output layer (identity activation).
    The compositional vector is ``w_t = softmax(Embedding(num_tasks, K)[t])`` with an orthogonal embedding
    initialisation (so ``w`` lies on the simplex). Hidden layers are orthogonally initialised (gain ``sqrt(2)``), the
    output layer with gain 1, biases zero; the ``K`` sets of a layer start as identical copies (MTBench/PaCo's
    ``kernel_identical_init``), so all tasks produce the same output at initialisation. Set
    ``identical_init=False`` to initialise the sets independently. Not reproduced: the original PaCo's
    loss-masking / ``w``-reset stability trick (MTBench does not use it either).
    """

    def __init__(
        self,
        obs_dim: int,
        out_dim: int,
        num_tasks: int,
        num_sets: int = 5,
        hidden_dim: int = 400,
        num_layers: int = 3,
        activation: str = "relu",
        identical_init: bool = True,
    ) -> None:
        super().__init__()
        state_dim = check_sizes("paco", obs_dim, out_dim, num_tasks)
        if num_sets < 1:
            raise ValueError(f"paco: num_sets (K) must be >= 1, got {num_sets}")
        if num_layers < 0:
            raise ValueError(f"paco: num_layers must be >= 0, got {num_layers}")
        self.obs_dim = obs_dim
        self.num_tasks = num_tasks
        self.num_sets = num_sets
        self.task_encoder = nn.Embedding(num_tasks, num_sets)
        nn.init.orthogonal_(self.task_encoder.weight)
        hidden_init = functools.partial(nn.init.orthogonal_, gain=nn.init.calculate_gain("relu"))
        out_init = functools.partial(nn.init.orthogonal_, gain=1.0)
        layers = []
        width = state_dim
        for _ in range(num_layers):
            layers.append(CompositionalLinear(num_sets, width, hidden_dim, weight_init=hidden_init, identical_init=identical_init))
            width = hidden_dim
        self.layers = nn.ModuleList(layers)
        self.output_layer = CompositionalLinear(num_sets, width, out_dim, weight_init=out_init, identical_init=identical_init)
        self.act = activation_class(activation)()

    def compositional_weights(self, task_id: torch.Tensor) -> torch.Tensor:
        """Compositional vectors ``softmax(Embedding[task_id])``, shape ``[*task_id.shape, K]``."""
        return torch.softmax(self.task_encoder(task_id), dim=-1)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        obs, tid, batch_shape = flatten_inputs(observation, task_id, self.obs_dim, "paco")
        w = task_rows(torch.softmax(self.task_encoder.weight, dim=-1), tid)  # [B, K]
        x = obs[:, : -self.num_tasks]
        for layer in self.layers:
            x = self.act(layer(x, w))
        return unflatten_output(self.output_layer(x, w), batch_shape)
