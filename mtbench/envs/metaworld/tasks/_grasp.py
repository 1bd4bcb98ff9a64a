"""Pieces shared by the grasping tasks (push, pick_place, peg_insert_side).

* The "grasped and lifted" test of the pick-place / peg rewards (MTBench and Meta-World).
"""

from __future__ import annotations

import torch


def grasped_and_lifted(tcp_to_obj: torch.Tensor, tcp_opened: torch.Tensor, obj_z: torch.Tensor,
                       obj_init_z: torch.Tensor, reach_radius: float) -> torch.Tensor:
    """Meta-World's "object held up" test: TCP within ``reach_radius`` of the object, gripper not fully closed
    (``obs[3] > 0``) and the object more than 1 cm above its initial height. ``[N]`` bool."""
    return (tcp_to_obj < reach_radius) & (tcp_opened > 0) & (obj_z - 0.01 > obj_init_z)
