"""The env of a run from its ``env`` config."""

from __future__ import annotations

from typing import Any, Mapping

import torch
from omegaconf import OmegaConf
from torchrl.envs import EnvBase


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


__all__ = ["make_env_from_cfg"]
