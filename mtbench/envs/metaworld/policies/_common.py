"""Observation parsing and small control helpers shared by the scripted policies."""

from __future__ import annotations

import torch

from ..observation import parse
from ..robot import ACTION_SCALE

__all__ = ["action", "move", "parse"]


def move(hand: torch.Tensor, target: torch.Tensor, gain: float = 1.0) -> torch.Tensor:
    """Displacement action towards ``target``: full speed far away, proportional near it."""
    return ((target - hand) * (gain / ACTION_SCALE)).clamp(-1.0, 1.0)


def action(delta: torch.Tensor, grip: torch.Tensor | float) -> torch.Tensor:
    """Assemble ``[dx, dy, dz, grip]`` (grip +1 closes the gripper)."""
    grip_t = torch.as_tensor(grip, dtype=delta.dtype, device=delta.device).expand(delta.shape[:-1])
    return torch.cat([delta, grip_t[..., None]], dim=-1)
