"""Checks of what users hand to a batched env (``env.step``'s action, ``env.reset``'s ``_reset`` mask): one clear
``ValueError`` each, from shape and dtype metadata only (no device synchronisation)."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase


def checked_action(tensordict: TensorDictBase, num_envs: int, action_dim: int, values: str) -> torch.Tensor:
    """``tensordict["action"]`` if it has shape ``[num_envs, action_dim]``; else a ``ValueError`` naming the expected
    shape and ``values`` (e.g. ``"values in [-1, 1]"``)."""
    action = tensordict.get("action", None)
    expected = (num_envs, action_dim)
    if action is None or tuple(action.shape) != expected:
        got = "no 'action' entry" if action is None else f"shape {list(action.shape)}"
        raise ValueError(f"env.step needs tensordict['action'] of shape [num_envs, {action_dim}] = "
                         f"{list(expected)} ({values}); got {got}")
    return action


def reset_mask(tensordict: TensorDictBase | None, num_envs: int, device: torch.device) -> torch.Tensor:
    """The worlds to reset: ``tensordict["_reset"]`` (a bool ``[num_envs]`` or ``[num_envs, 1]`` mask) flattened,
    all worlds without one; else a ``ValueError``."""
    if tensordict is None or "_reset" not in tensordict.keys():
        return torch.ones(num_envs, dtype=torch.bool, device=device)
    reset = tensordict.get("_reset")
    if reset.dtype != torch.bool or tuple(reset.shape) not in ((num_envs,), (num_envs, 1)):
        raise ValueError(f"env.reset: '_reset' must be a bool mask of shape [num_envs] or [num_envs, 1] = "
                         f"[{num_envs}] or [{num_envs}, 1]; got {reset.dtype} of shape {list(reset.shape)}")
    return reset.reshape(num_envs).to(device)


__all__ = ["checked_action", "reset_mask"]
