"""Actor (Gaussian policy with a state-independent log-std) and critic builders from an arch preset."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import torch
from tensordict.nn import InteractionType, TensorDictModule
from torch import nn
from torchrl.modules import IndependentNormal, ProbabilisticActor

from ..modules import make_network

DEFAULT_ARCH: dict[str, Any] = {"name": "mlp", "kwargs": {"hidden": [256, 128, 64], "activation": "elu"}}


class GaussianPolicyHead(nn.Module):
    """Wrap a network producing the action mean; add a state-independent ``log_std`` parameter.

    ``forward(observation, task_id) -> (loc, scale)`` with ``scale = exp(log_std)`` broadcast to ``loc``
    (rl_games ``fixed_sigma: True``; MTBench initialises ``log_std`` to 0, i.e. sigma = 1).
    """

    def __init__(self, net: nn.Module, action_dim: int, log_std_init: float = 0.0) -> None:
        super().__init__()
        self.net = net
        self.log_std = nn.Parameter(torch.full((action_dim,), float(log_std_init)))

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        loc = self.net(observation, task_id)
        scale = self.log_std.exp().expand_as(loc)
        return loc, scale


def _plain(value: Any) -> Any:
    try:
        from omegaconf import DictConfig, ListConfig, OmegaConf

        if isinstance(value, (DictConfig, ListConfig)):
            return OmegaConf.to_container(value, resolve=True)
    except ImportError:  # pragma: no cover
        pass
    return value


def resolve_arch(arch_cfg: Mapping[str, Any] | None, role: str) -> tuple[str, dict[str, Any]]:
    """Merge an arch preset (schema ``name``, ``kwargs``, ``actor``, ``critic``) for ``role``.

    Returns ``(name, {**kwargs, **preset[role]})``; ``None`` gives the MTBench default MLP [256,128,64] ELU.
    """
    if role not in ("actor", "critic"):
        raise ValueError(f"unknown role {role!r}; valid choices: ['actor', 'critic']")
    cfg = dict(_plain(arch_cfg)) if arch_cfg is not None else dict(DEFAULT_ARCH)
    if "name" not in cfg:
        raise ValueError(f"arch config needs a 'name'; got keys {sorted(cfg)}")
    merged: dict[str, Any] = {}
    for part in (cfg.get("kwargs") or {}, cfg.get(role) or {}):
        merged.update({str(k): _plain(v) for k, v in dict(part).items()})
    return str(cfg["name"]), merged


def make_actor(
    arch_cfg: Mapping[str, Any] | None,
    *,
    obs_dim: int,
    action_dim: int,
    num_tasks: int,
    task_descriptions: Sequence[str] | None = None,
    log_std_init: float = 0.0,
    device: torch.device | str | None = None,
) -> ProbabilisticActor:
    """Gaussian actor: ``(observation, task_id) -> loc, scale -> action ~ IndependentNormal``, with
    ``action_log_prob``. Actions are not squashed (the env clamps them to [-1, 1])."""
    name, kwargs = resolve_arch(arch_cfg, "actor")
    net = make_network(name, obs_dim=obs_dim, out_dim=action_dim, num_tasks=num_tasks,
                       task_descriptions=task_descriptions, **kwargs)
    head = GaussianPolicyHead(net, action_dim, log_std_init)
    module = TensorDictModule(head, in_keys=["observation", "task_id"], out_keys=["loc", "scale"])
    actor = ProbabilisticActor(
        module,
        in_keys=["loc", "scale"],
        out_keys=["action"],
        distribution_class=IndependentNormal,
        return_log_prob=True,
        default_interaction_type=InteractionType.RANDOM,
    )
    return actor.to(device) if device is not None else actor


def make_critic(
    arch_cfg: Mapping[str, Any] | None,
    *,
    obs_dim: int,
    num_tasks: int,
    task_descriptions: Sequence[str] | None = None,
    device: torch.device | str | None = None,
) -> TensorDictModule:
    """Value network ``(observation, task_id) -> state_value [..., 1]`` (normalised values for MT-PPO)."""
    name, kwargs = resolve_arch(arch_cfg, "critic")
    net = make_network(name, obs_dim=obs_dim, out_dim=1, num_tasks=num_tasks, task_descriptions=task_descriptions,
                       **kwargs)
    critic = TensorDictModule(net, in_keys=["observation", "task_id"], out_keys=["state_value"])
    return critic.to(device) if device is not None else critic

