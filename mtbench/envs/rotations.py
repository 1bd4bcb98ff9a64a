"""Quaternion helpers for MuJoCo's ``(w, x, y, z)`` convention (batched torch), shared by the env families."""

from __future__ import annotations

import torch


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate vectors ``v`` ``[N, 3]`` given in the frame of unit quaternions ``q`` ``[N, 4]`` (w, x, y, z) into the
    world frame."""
    w, u = q[:, :1], q[:, 1:]
    t = 2.0 * torch.cross(u, v, dim=-1)
    return v + w * t + torch.cross(u, t, dim=-1)


def quat_rotate_inverse(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate world-frame vectors ``v`` ``[N, 3]`` into the frame of unit quaternions ``q`` ``[N, 4]`` (w, x, y, z)."""
    w, u = q[:, :1], q[:, 1:]
    t = 2.0 * torch.cross(u, v, dim=-1)
    return v - w * t + torch.cross(u, t, dim=-1)


def euler_from_quat(q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Roll, pitch, yaw (intrinsic z-y-x, radians) of unit quaternions ``[N, 4]`` (w, x, y, z); pitch is clipped to
    ``[-pi/2, pi/2]`` as in the original's ``euler_from_quaternion``."""
    w, x, y, z = q.unbind(-1)
    roll = torch.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = torch.asin(torch.clamp(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = torch.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw

