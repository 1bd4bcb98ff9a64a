"""The decomposed Q network of MT-PQN (DecQN, Seyde et al. 2023) over any ``arch=`` trunk, and its epsilon-greedy
policy from stock TorchRL modules.

With ``A`` action dimensions of ``bins`` values each, the network outputs per-dimension utilities
``Q_j(s, b)`` of shape ``[..., A, bins]``; the greedy action takes the arg-max of every dimension independently,
``Q(s, a) = 1/A sum_j Q_j(s, a_j)`` and the greedy value ``V(s) = 1/A sum_j max_b Q_j(s, b)`` (MTBench
``pqn_agent.py``: ``gather(...).mean(-1)`` and ``max(dim=2).mean(-1)``; the paper's appendix eq. 1).
"""

from __future__ import annotations

from typing import Sequence

import torch
from tensordict.nn import TensorDictModule, TensorDictSequential
from tensordict.utils import NestedKey
from torch import nn
from torchrl.data import TensorSpec
from torchrl.modules import EGreedyModule, QValueModule

from .registry import make_network


class DecomposedQNetwork(nn.Module):
    """``forward(observation, task_id) -> [..., A, bins]``: the trunk's ``A * bins`` outputs, one row of ``bins``
    utilities per action dimension.

    Args:
        net: any network of :func:`~mtbench.modules.make_network` with ``out_dim = action_dim * bins``.
        action_dim: A.
        bins: values per action dimension.
    """

    def __init__(self, net: nn.Module, action_dim: int, bins: int) -> None:
        super().__init__()
        self.net = net
        self.action_dim = int(action_dim)
        self.bins = int(bins)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        out = self.net(observation, task_id)
        return out.unflatten(-1, (self.action_dim, self.bins))


def decomposed_q_value(action_value: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
    """``Q(s, a) = mean_j Q_j(s, a_j)``: ``action_value [..., A, bins]``, integer ``action [..., A]`` -> ``[...]``."""
    chosen = action_value.gather(-1, action.long().unsqueeze(-1)).squeeze(-1)
    return chosen.mean(-1)


def greedy_value(action_value: torch.Tensor) -> torch.Tensor:
    """``V(s) = max_a Q(s, a) = mean_j max_b Q_j(s, b)``: ``[..., A, bins]`` -> ``[...]``."""
    return action_value.amax(-1).mean(-1)


def make_q_network(
    arch: str,
    *,
    obs_dim: int,
    action_dim: int,
    bins: int,
    num_tasks: int,
    task_descriptions: Sequence[str] | None = None,
    in_keys: Sequence[NestedKey] = ("observation", "task_id"),
    out_key: NestedKey = "action_value",
    **kwargs,
) -> TensorDictModule:
    """``TensorDictModule(DecomposedQNetwork(make_network(arch, out_dim=action_dim * bins, ...)))`` writing the
    ``[..., A, bins]`` utilities to ``out_key``. ``kwargs`` are the architecture's (e.g. ``hidden_dim``)."""
    if not (isinstance(bins, int) and bins >= 2):
        raise ValueError(f"bins must be an integer >= 2 (values per action dimension); got {bins!r}")
    if not (isinstance(action_dim, int) and action_dim >= 1):
        raise ValueError(f"action_dim must be an integer >= 1; got {action_dim!r}")
    net = make_network(arch, obs_dim=obs_dim, out_dim=action_dim * bins, num_tasks=num_tasks,
                       task_descriptions=task_descriptions, **kwargs)
    return TensorDictModule(DecomposedQNetwork(net, action_dim, bins), in_keys=list(in_keys), out_keys=[out_key])


def make_q_policy(
    q_network: TensorDictModule,
    action_spec: TensorSpec,
    *,
    eps_init: float = 1.0,
    eps_end: float = 0.005,
    action_key: NestedKey = "action",
) -> TensorDictSequential:
    """Epsilon-greedy policy of a decomposed Q network from stock TorchRL modules:
    ``q_network`` -> ``QValueModule(action_space="categorical")`` (per-dimension arg-max ``action [..., A]``,
    ``chosen_action_value [..., A, 1]``) -> ``EGreedyModule(action_spec)``: with probability ``eps`` a world's
    whole action is replaced by uniform bins (one draw per world, all dimensions jointly, as MTBench).

    ``action_spec`` is the env's ``Categorical(bins, shape=[N, A])`` (see
    :class:`~mtbench.envs.discrete_actions.DiscreteActions`). The exploration rate is the ``eps`` buffer of the
    ``EGreedyModule`` (set it in place, e.g. with :class:`~mtbench.trainer.hooks.EpsilonSchedule`; TorchRL's
    ``EGreedyModule.step(frames)`` loops ``frames`` times). Under ``set_exploration_type(DETERMINISTIC)`` the
    policy is greedy.
    """
    value_key = q_network.out_keys[0]
    greedy = QValueModule(action_space="categorical", action_value_key=value_key,
                          out_keys=[action_key, value_key, "chosen_action_value"], strict_shape=False)
    explore = EGreedyModule(action_spec, eps_init=float(eps_init), eps_end=float(eps_end), action_key=action_key,
                            device=action_spec.device)
    return TensorDictSequential(q_network, greedy, explore)


__all__ = ["DecomposedQNetwork", "decomposed_q_value", "greedy_value", "make_q_network", "make_q_policy"]
