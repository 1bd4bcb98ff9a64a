"""Control helpers shared by the group-d scripted policies (bins, nut, lid, ball, stick tasks)."""

from __future__ import annotations

import torch


def preshaped_grip(opened: torch.Tensor, close: torch.Tensor, width: float, band: float = 0.03) -> torch.Tensor:
    """Gripper effort ``[N]``: +1 where ``close``, else hold the openness near ``width`` (bang-bang with a dead band
    of ±``band``), so that the fingers come down only as far apart as needed (e.g. inside a bin's walls)."""
    pre = torch.where(opened > width + band, 1.0, torch.where(opened < width - band, -1.0, 0.0))
    return torch.where(close, 1.0, pre)


def with_z(xy: torch.Tensor, z: torch.Tensor | float) -> torch.Tensor:
    """Points ``[N, 3]`` from x-y ``[N, 2]`` (or the first two columns of ``[N, 3]``) and a height."""
    z_t = torch.full_like(xy[:, 0], z) if isinstance(z, float) else z
    return torch.stack([xy[:, 0], xy[:, 1], z_t], dim=-1)

