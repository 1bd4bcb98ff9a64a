"""CARE (Sodhani et al., 2021): a mixture of state encoders attended by a task-description context."""

from __future__ import annotations

import os
import warnings
from typing import Sequence

import torch
from torch import nn

from .experts import ParallelExperts, mix_experts
from .inputs import check_sizes, flatten_inputs, unflatten_output
from .mlp import mlp_layers
from .stacked_linear import StackedLinear
from .task_embeddings import pretrained_task_embeddings
from .task_rows import task_rows

_ATTENTIONS = ("dot", "task")
_CONTEXTS = ("pretrained", "learned")


def _xavier_zero_bias(module: nn.Module) -> None:
    relu_gain = nn.init.calculate_gain("relu")
    for m in module.modules():
        if isinstance(m, nn.Linear):
            nn.init.xavier_uniform_(m.weight, gain=relu_gain)
            if m.bias is not None:
                nn.init.zeros_(m.bias)


class CARE(nn.Module):
    """Contextual Attention-based REpresentations; ``multi_head=False`` is MTBench's SH-CARE, ``True`` MH-CARE.

    * Context ``z_ctx`` (per task): frozen sentence embedding of the task description (``context="pretrained"``,
      default: the paper uses pretrained-language-model embeddings of task metadata) -> ReLU -> projection
      ``Linear(d, 2d) ReLU Linear(2d, d) ReLU`` (MTBench) -> context MLP ``[50, 50]`` ReLU.
      ``context="learned"`` replaces the frozen table by a trainable ``Embedding(num_tasks, learned_embedding_dim)``
      feeding the context MLP directly. ``"pretrained"`` falls back to ``"learned"`` (with a warning) when
      ``task_descriptions`` (one sentence per task, e.g. ``env.task_descriptions``) is not given or the encoder
      package is missing and the embeddings are not cached.
    * Mixture of ``num_experts`` encoders on the state (``num_layers`` layers of width ``hidden_dim`` = D = 50).
    * Attention (default ``"dot"``, MTBench): ``alpha_e = softmax_e(z_ctx.detach() . phi_e(s) / T)``, state
      dependent; then ``z_enc = sum_e alpha_e phi_e(s)`` goes through the post-attention MLP ``attention_hidden``.
      ``"task"`` (mtrl's reference CARE): ``alpha = softmax(MLP(z_ctx.detach()) / T)`` with ``attention_hidden``
      as the hidden layers of that MLP (then no post-attention MLP); the weights depend on the task only.
    * Trunk MLP ``hidden`` (``[400, 400, 400]`` ReLU) on ``concat(z_enc, z_ctx)``, then one ``Linear`` head (SH) or
      one head per task (MH, gathered by ``task_id``).

    Initialisation: per-expert Xavier with zero biases (mtrl's; MTBench's 3-D xavier / ``U[0,1)`` bias quirk is
    not reproduced), Xavier (ReLU gain) + zero bias for the MLPs, Xavier (gain 1) for the heads.
    Task-only sub-networks (context encoder, task attention) are evaluated on the ``num_tasks`` rows and gathered.
    """

    def __init__(
        self,
        obs_dim: int,
        out_dim: int,
        num_tasks: int,
        task_descriptions: Sequence[str] | None = None,
        num_experts: int = 6,
        num_layers: int = 2,
        hidden_dim: int = 50,
        temperature: float = 1.0,
        attention: str = "dot",
        attention_hidden: Sequence[int] = (50, 50),
        context: str = "pretrained",
        context_hidden: Sequence[int] = (50, 50),
        learned_embedding_dim: int = 50,
        hidden: Sequence[int] = (400, 400, 400),
        multi_head: bool = False,
        embedding_cache_dir: str | os.PathLike[str] | None = None,
    ) -> None:
        super().__init__()
        state_dim = check_sizes("care", obs_dim, out_dim, num_tasks)
        if attention not in _ATTENTIONS:
            raise ValueError(f"care: unknown attention {attention!r}; valid choices: {list(_ATTENTIONS)}")
        if context not in _CONTEXTS:
            raise ValueError(f"care: unknown context {context!r}; valid choices: {list(_CONTEXTS)}")
        if temperature <= 0:
            raise ValueError(f"care: temperature must be > 0, got {temperature}")
        if not context_hidden:
            raise ValueError("care: context_hidden must have at least one layer")
        if attention == "dot" and context_hidden[-1] != hidden_dim:
            raise ValueError(
                f"care: dot-product attention needs context_hidden[-1] ({context_hidden[-1]}) == hidden_dim ({hidden_dim})"
            )
        if task_descriptions is not None and len(task_descriptions) != num_tasks:
            raise ValueError(f"care: got {len(task_descriptions)} task_descriptions for num_tasks={num_tasks}")
        self.obs_dim = obs_dim
        self.num_tasks = num_tasks
        self.temperature = float(temperature)
        self.attention = attention
        self.multi_head = multi_head

        table = self._pretrained_table(task_descriptions, embedding_cache_dir) if context == "pretrained" else None
        self.context = "pretrained" if table is not None else "learned"
        if table is not None:
            self.register_buffer("context_table", table)  # frozen: a buffer, never a trainable parameter
            d = table.shape[1]
            self.context_embedding = None
            self.context_projection = nn.Sequential(nn.Linear(d, 2 * d), nn.ReLU(), nn.Linear(2 * d, d), nn.ReLU())
            ctx_in = d
        else:
            self.context_table = None
            self.context_embedding = nn.Embedding(num_tasks, learned_embedding_dim)
            self.context_projection = None
            ctx_in = learned_embedding_dim
        self.context_mlp, ctx_dim = mlp_layers(ctx_in, context_hidden, "relu")

        self.experts = ParallelExperts(num_experts, state_dim, hidden_dim, hidden_dim, num_layers)
        if attention == "dot":
            self.attention_mlp, enc_dim = mlp_layers(hidden_dim, attention_hidden, "relu")
            self.attention_logits = None
        else:
            trunk, width = mlp_layers(ctx_dim, attention_hidden, "relu")
            self.attention_mlp = None
            self.attention_logits = nn.Sequential(*trunk, nn.Linear(width, num_experts))
            enc_dim = hidden_dim
        self.trunk, width = mlp_layers(enc_dim + ctx_dim, hidden, "relu")
        _xavier_zero_bias(self)
        if multi_head:
            self.heads: StackedLinear | nn.Linear = StackedLinear(num_tasks, width, out_dim).xavier_(1.0)
        else:
            self.heads = nn.Linear(width, out_dim)
            nn.init.xavier_uniform_(self.heads.weight)
            nn.init.zeros_(self.heads.bias)
        if self.attention_logits is not None:
            nn.init.xavier_uniform_(self.attention_logits[-1].weight)

    @staticmethod
    def _pretrained_table(
        task_descriptions: Sequence[str] | None, cache_dir: str | os.PathLike[str] | None
    ) -> torch.Tensor | None:
        if task_descriptions is None:
            warnings.warn("care: no task_descriptions given; using learned task embeddings (context='learned')",
                          stacklevel=3)
            return None
        try:
            return pretrained_task_embeddings(task_descriptions, cache_dir=cache_dir)
        except ImportError as err:
            warnings.warn(f"care: {err}; using learned task embeddings (context='learned')", stacklevel=3)
            return None

    def task_contexts(self) -> torch.Tensor:
        """Context vectors ``z_ctx`` of all tasks, ``[num_tasks, context_hidden[-1]]``."""
        if self.context_table is not None:
            emb = self.context_projection(torch.relu(self.context_table))
        else:
            emb = self.context_embedding.weight
        return self.context_mlp(emb)

    def _attend(self, state: torch.Tensor, tid: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        contexts = self.task_contexts()
        z_ctx = task_rows(contexts, tid)
        reprs = self.experts(state)  # [E, B, D]
        if self.attention == "dot":
            scores = (z_ctx.detach().unsqueeze(0) * reprs).sum(-1).t()  # [B, E] (not a batched GEMM: see mix_experts)
        else:
            scores = task_rows(self.attention_logits(contexts.detach()), tid)
        alpha = torch.softmax(scores / self.temperature, dim=-1)  # [B, E]
        return alpha, reprs, z_ctx

    def attention_weights(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        """Attention weights over the encoders, ``[*batch, num_experts]`` (sum to 1)."""
        obs, tid, batch_shape = flatten_inputs(observation, task_id, self.obs_dim, "care")
        alpha = self._attend(obs[:, : -self.num_tasks], tid)[0]
        return unflatten_output(alpha, batch_shape)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        obs, tid, batch_shape = flatten_inputs(observation, task_id, self.obs_dim, "care")
        alpha, reprs, z_ctx = self._attend(obs[:, : -self.num_tasks], tid)
        z_enc = mix_experts(alpha, reprs)
        if self.attention_mlp is not None:
            z_enc = self.attention_mlp(z_enc)
        h = self.trunk(torch.cat([z_enc, z_ctx], dim=-1))
        out = self.heads.forward_selected(h, tid) if self.multi_head else self.heads(h)
        return unflatten_output(out, batch_shape)
