"""The Parkour observation layout (233 = proprio 48 + scandots 132 + base linear velocity 3 + privileged latent 29
+ task one-hot 21): the one place that defines its order, sizes and scales (MTBench ``legged_base.py``
``compute_observations`` with ``final_go1_*.yaml``: ``history_len 0``, scandots unscaled, clip +-100).

Each entry is ``(name, size, scale)``; :data:`SLICES` maps a name to its columns. :func:`assemble` takes the raw
(unscaled) quantities by name and returns the clipped observation.

| name | size | value |
|---|---|---|
| base_ang_vel | 3 | base angular velocity (base frame) x 0.25 |
| roll_pitch | 2 | base roll, pitch (rad) |
| delta_yaw | 1 | target yaw - yaw, not wrapped, refreshed every 5 steps |
| delta_next_yaw | 1 | next-goal yaw - yaw, not wrapped, refreshed every 5 steps |
| command | 1 | commanded forward speed (m/s) |
| joint_pos | 12 | q - q_default |
| joint_vel | 12 | qdot x 0.05 |
| last_action | 12 | the policy's previous action as given (before clipping) |
| foot_contact | 4 | filtered foot contact (force > 2 N now or at the previous step) - 0.5 |
| scandots | 132 | clip(base_z - 0.3 - h, -1, 1) at the scan points, refreshed every 5 steps |
| base_lin_vel | 3 | the trunk's centre-of-mass velocity (base frame) x 2.0 |
| added_mass | 1 | mass added to the trunk (kg) |
| com_offset | 3 | trunk centre-of-mass offset (m) |
| friction | 1 | robot friction coefficient |
| motor_strength_p | 12 | ms0 - 1 |
| motor_strength_d | 12 | ms1 - 1 |
| task_one_hot | 21 | one-hot of the canonical task id |
"""

from __future__ import annotations

from typing import Mapping

import torch

NUM_TASK_SLOTS = 21
OBS_CLIP = 100.0
SCANDOT_OFFSET = 0.3  # m subtracted from base_z - ground height

LAYOUT: tuple[tuple[str, int, float], ...] = (
    ("base_ang_vel", 3, 0.25),
    ("roll_pitch", 2, 1.0),
    ("delta_yaw", 1, 1.0),
    ("delta_next_yaw", 1, 1.0),
    ("command", 1, 1.0),
    ("joint_pos", 12, 1.0),
    ("joint_vel", 12, 0.05),
    ("last_action", 12, 1.0),
    ("foot_contact", 4, 1.0),
    ("scandots", 132, 1.0),
    ("base_lin_vel", 3, 2.0),
    ("added_mass", 1, 1.0),
    ("com_offset", 3, 1.0),
    ("friction", 1, 1.0),
    ("motor_strength_p", 12, 1.0),
    ("motor_strength_d", 12, 1.0),
    ("task_one_hot", NUM_TASK_SLOTS, 1.0),
)


def _slices() -> dict[str, slice]:
    out, start = {}, 0
    for name, size, _ in LAYOUT:
        out[name] = slice(start, start + size)
        start += size
    return out


SLICES: dict[str, slice] = _slices()
SCALES: dict[str, float] = {name: scale for name, _, scale in LAYOUT}
OBS_DIM = sum(size for _, size, _ in LAYOUT)  # 233
STATE_DIM = OBS_DIM - NUM_TASK_SLOTS  # 212
GROUPS = {  # the original's five blocks
    "proprio": slice(SLICES["base_ang_vel"].start, SLICES["foot_contact"].stop),  # 48
    "scandots": SLICES["scandots"],  # 132
    "priv_explicit": SLICES["base_lin_vel"],  # 3
    "priv_latent": slice(SLICES["added_mass"].start, SLICES["motor_strength_d"].stop),  # 29
    "task_one_hot": SLICES["task_one_hot"],  # 21
}


def scandots(base_z: torch.Tensor, ground: torch.Tensor) -> torch.Tensor:
    """``clip(base_z - 0.3 - h, -1, 1)`` for ground heights ``h`` ``[N, P]`` under bases at height ``base_z``
    ``[N]``."""
    return torch.clamp(base_z[:, None] - SCANDOT_OFFSET - ground, -1.0, 1.0)


def assemble(parts: Mapping[str, torch.Tensor], out: torch.Tensor | None = None) -> torch.Tensor:
    """The observation ``[N, 233]`` from raw quantities ``parts[name]`` (``[N]`` or ``[N, size]``), each multiplied
    by its scale, then clipped to ``+-OBS_CLIP``; written into ``out`` if given."""
    cols = []
    for name, size, scale in LAYOUT:
        value = parts[name]
        if value.dim() == 1:
            value = value[:, None]
        if value.shape[-1] != size:
            raise ValueError(f"observation part {name!r} has {value.shape[-1]} columns, expected {size}")
        cols.append(value * scale if scale != 1.0 else value)
    obs = torch.clamp(torch.cat(cols, dim=-1), -OBS_CLIP, OBS_CLIP)
    if out is None:
        return obs
    out.copy_(obs)
    return out
