"""MT-SAC's networks from an arch preset: the tanh-Gaussian actor (state-dependent std) and the Q network
``Q(s, a)``, both built with :func:`mtbench.modules.make_network` like the MT-PPO actor and critic."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import torch
from tensordict.nn import InteractionType, TensorDictModule
from torch import nn
from torch.distributions import Independent, Normal, TanhTransform, TransformedDistribution
from torchrl.data import Bounded
from torchrl.modules import ProbabilisticActor

from ..modules import make_network
from .actor_critic import resolve_arch


class SquashedNormal(TransformedDistribution):
    """``tanh(u)``, ``u ~ N(loc, scale)`` with independent action dimensions (SAC's policy; rl_games /
    pytorch_sac ``SquashedNormal``): ``log_prob`` sums over the last dimension, so it is ``[*batch]``.

    ``rsample`` caches the pre-tanh sample, so ``log_prob`` of that very sample uses the stable
    ``log|d tanh(u)/du| = 2 (log 2 - u - softplus(-2u))`` without ``atanh``. Arguments are not validated (the
    checks would read tensors on the host); ``deterministic_sample`` is ``tanh(loc)``.
    """

    def __init__(self, loc: torch.Tensor, scale: torch.Tensor) -> None:
        base = Independent(Normal(loc, scale, validate_args=False), 1, validate_args=False)
        super().__init__(base, [TanhTransform(cache_size=1)], validate_args=False)
        self.loc, self.scale = loc, scale

    @property
    def deterministic_sample(self) -> torch.Tensor:
        """``tanh(loc)``: the action of the deterministic policy (evaluation)."""
        return torch.tanh(self.loc)

    @property
    def mode(self) -> torch.Tensor:
        return self.deterministic_sample


class TanhGaussianHead(nn.Module):
    """Wrap a network producing ``2 |A|`` features into the parameters of :class:`SquashedNormal`.

    ``forward(observation, task_id) -> (loc, scale)``: the first half is the mean, the second half the log-std,
    clamped to ``[log_std_min, log_std_max]`` (rl_games ``DiagGaussianActor``, which MTBench's MT-SAC uses, with
    ``log_std_bounds: [-20, 2]``; its tanh rescaling is commented out there), ``scale = exp(log_std)``.
    """

    def __init__(self, net: nn.Module, action_dim: int, log_std_min: float = -20.0, log_std_max: float = 2.0) -> None:
        super().__init__()
        if not log_std_min < log_std_max:
            raise ValueError(f"loss.log_std_bounds must be [min, max] with min < max; got [{log_std_min}, "
                             f"{log_std_max}]")
        self.net = net
        self.action_dim = int(action_dim)
        self.log_std_min, self.log_std_max = float(log_std_min), float(log_std_max)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        loc, log_std = self.net(observation, task_id).chunk(2, dim=-1)
        return loc, log_std.clamp(self.log_std_min, self.log_std_max).exp()


class QValueHead(nn.Module):
    """``Q(s, a)`` on an arch network: the action is inserted between the state and the one-hot task id,
    ``net([state, action, one_hot], task_id) -> [..., 1]``, so every architecture (which reads the state as
    ``observation[..., :-num_tasks]``) sees the state-action pair as its state part."""

    def __init__(self, net: nn.Module, num_tasks: int) -> None:
        super().__init__()
        self.net = net
        self.num_tasks = int(num_tasks)

    def forward(self, observation: torch.Tensor, action: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        k = self.num_tasks
        x = torch.cat([observation[..., :-k], action, observation[..., -k:]], dim=-1)
        return self.net(x, task_id)


def make_sac_actor(
    arch_cfg: Mapping[str, Any] | None,
    *,
    obs_dim: int,
    action_dim: int,
    num_tasks: int,
    task_descriptions: Sequence[str] | None = None,
    log_std_bounds: Sequence[float] = (-20.0, 2.0),
    device: torch.device | str | None = None,
) -> ProbabilisticActor:
    """Tanh-Gaussian actor ``(observation, task_id) -> loc, scale -> action ~ SquashedNormal`` (actions in
    ``(-1, 1)``), the arch preset's ``actor`` network with ``2 |A|`` outputs. It writes ``loc``, ``scale`` and
    ``action``; TorchRL's ``SACLoss`` draws its own reparameterised samples from it. Its ``spec`` is the action
    box ``[-1, 1]^|A|`` (``SACLoss(target_entropy="auto")`` reads ``-|A|`` from it)."""
    name, kwargs = resolve_arch(arch_cfg, "actor")
    net = make_network(name, obs_dim=obs_dim, out_dim=2 * action_dim, num_tasks=num_tasks,
                       task_descriptions=task_descriptions, **kwargs)
    low, high = (float(b) for b in log_std_bounds)
    head = TanhGaussianHead(net, action_dim, low, high)
    module = TensorDictModule(head, in_keys=["observation", "task_id"], out_keys=["loc", "scale"])
    actor = ProbabilisticActor(
        module,
        in_keys=["loc", "scale"],
        out_keys=["action"],
        spec=Bounded(-1.0, 1.0, shape=(action_dim,), device=device),
        distribution_class=SquashedNormal,
        return_log_prob=False,
        default_interaction_type=InteractionType.RANDOM,
    )
    return actor.to(device) if device is not None else actor


def make_qvalue(
    arch_cfg: Mapping[str, Any] | None,
    *,
    obs_dim: int,
    action_dim: int,
    num_tasks: int,
    task_descriptions: Sequence[str] | None = None,
    device: torch.device | str | None = None,
) -> TensorDictModule:
    """Q network ``(observation, action, task_id) -> state_action_value [..., 1]``: the arch preset's
    ``critic`` network on ``obs_dim + |A|`` inputs (see :class:`QValueHead`)."""
    name, kwargs = resolve_arch(arch_cfg, "critic")
    net = make_network(name, obs_dim=obs_dim + action_dim, out_dim=1, num_tasks=num_tasks,
                       task_descriptions=task_descriptions, **kwargs)
    q = TensorDictModule(QValueHead(net, num_tasks), in_keys=["observation", "action", "task_id"],
                         out_keys=["state_action_value"])
    return q.to(device) if device is not None else q


__all__ = ["QValueHead", "SquashedNormal", "TanhGaussianHead", "make_qvalue", "make_sac_actor"]
