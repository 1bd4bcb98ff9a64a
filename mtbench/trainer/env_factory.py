"""The env of a run from its ``env`` config."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import torch
from omegaconf import OmegaConf
from torchrl.envs import EnvBase

from .rollout import base_env


@dataclass(frozen=True)
class NetworkSizes:
    """What the networks of a run are sized from: the (possibly transformed) env's observation and action widths,
    the number of tasks and the task descriptions (CARE's context; ``None``: learned task embeddings)."""

    obs_dim: int
    action_dim: int
    num_tasks: int
    task_descriptions: list[str] | None


def network_sizes(env: EnvBase) -> NetworkSizes:
    """The :class:`NetworkSizes` of ``env`` (mtbench contract: ``num_tasks``, optional ``task_descriptions``)."""
    base = base_env(env)
    descriptions = getattr(base, "task_descriptions", None)
    return NetworkSizes(
        obs_dim=int(env.observation_spec["observation"].shape[-1]),
        action_dim=int(env.action_spec.shape[-1]),
        num_tasks=int(base.num_tasks),
        task_descriptions=list(descriptions) if descriptions is not None else None,
    )


def make_env_from_cfg(env_cfg: Mapping[str, Any], device: torch.device | str, seed: int) -> EnvBase:
    """``mtbench.envs.make_env(env_cfg.name, num_envs=env_cfg.num_envs, device=..., seed=..., **overrides)``."""
    from ..envs import make_env

    raw = env_cfg.get("overrides")
    if raw is None:
        overrides: dict[str, Any] = {}
    elif OmegaConf.is_config(raw):
        overrides = dict(OmegaConf.to_container(raw, resolve=True))  # type: ignore[arg-type]
    else:
        overrides = dict(raw)
    name = env_cfg["name"]
    if isinstance(name, (list, tuple)) or OmegaConf.is_list(name):
        name = list(name)
    return make_env(name, num_envs=env_cfg["num_envs"], device=device, seed=seed, **overrides)


__all__ = ["NetworkSizes", "make_env_from_cfg", "network_sizes"]
