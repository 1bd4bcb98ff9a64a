"""Observation parsing and small control helpers shared by the scripted policies."""

from __future__ import annotations

import torch

from ..robot import ACTION_SCALE


def parse(obs: torch.Tensor) -> dict[str, torch.Tensor]:
    """Split Meta-World's 39-d observation (extra trailing dims such as a one-hot are ignored)."""
    return {
        "hand": obs[..., 0:3],
        "gripper": obs[..., 3],
        "obj": obs[..., 4:7],
        "obj_quat": obs[..., 7:11],
        "obj2": obs[..., 11:14],
        "obj2_quat": obs[..., 14:18],
        "goal": obs[..., 36:39],
    }


def move(hand: torch.Tensor, target: torch.Tensor, gain: float = 1.0) -> torch.Tensor:
    """Displacement action towards ``target``: full speed far away, proportional near it."""
    return ((target - hand) * (gain / ACTION_SCALE)).clamp(-1.0, 1.0)


def action(delta: torch.Tensor, grip: torch.Tensor | float) -> torch.Tensor:
    """Assemble ``[dx, dy, dz, grip]`` (grip +1 closes the gripper)."""
    grip_t = torch.as_tensor(grip, dtype=delta.dtype, device=delta.device).expand(delta.shape[:-1])
    return torch.cat([delta, grip_t[..., None]], dim=-1)
