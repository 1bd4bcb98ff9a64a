"""Pieces shared by the grasping tasks (push, pick_place, peg_insert_side).

* Batched torch versions of the parts of Meta-World's v2 rewards that are not in :mod:`..reward_utils`: the
  pick-place variant of the caging reward (which measures the pads against their *initial* positions and uses
  signed pad-to-object offsets) and the "grasped and lifted" test of the pick-place / peg rewards.
"""

from __future__ import annotations

import torch

from ..reward_utils import hamacher_product, tolerance


def pick_place_caging_reward(
    action: torch.Tensor,
    obj_pos: torch.Tensor,
    *,
    left_pad: torch.Tensor,
    right_pad: torch.Tensor,
    tcp_center: torch.Tensor,
    obj_init_pos: torch.Tensor,
    init_tcp: torch.Tensor,
    init_left_pad: torch.Tensor,
    init_right_pad: torch.Tensor,
    obj_radius: float = 0.015,
    pad_success_margin: float = 0.05,
    xz_success_margin: float = 0.005,
) -> torch.Tensor:
    """Meta-World ``SawyerPickPlaceEnvV3._gripper_caging_reward`` (always "high density"), batched.

    Differences to the base caging reward (:func:`..reward_utils.gripper_caging_reward`): the pad-to-object
    offsets along y are *signed* (``left_pad_y - obj_y`` and ``obj_y - right_pad_y``: the left pad must be on the
    +y side, as the Panda's is), and the margins are ``| |obj_y - init_pad_y| - pad_success_margin |`` with the
    pad positions recorded at reset. Returns ``[N]`` in [0, 1].
    """
    delta_left = left_pad[..., 1] - obj_pos[..., 1]
    delta_right = obj_pos[..., 1] - right_pad[..., 1]
    left_margin = ((obj_pos[..., 1] - init_left_pad[..., 1]).abs() - pad_success_margin).abs()
    right_margin = ((obj_pos[..., 1] - init_right_pad[..., 1]).abs() - pad_success_margin).abs()
    bounds = (obj_radius, pad_success_margin)
    right_caging = tolerance(delta_right, bounds=bounds, margin=right_margin, sigmoid="long_tail")
    left_caging = tolerance(delta_left, bounds=bounds, margin=left_margin, sigmoid="long_tail")
    y_caging = hamacher_product(left_caging, right_caging)

    tcp_obj_xz = torch.linalg.vector_norm(tcp_center[..., ::2] - obj_pos[..., ::2], dim=-1)
    xz_margin = torch.linalg.vector_norm(obj_init_pos[..., ::2] - init_tcp[..., ::2], dim=-1) - xz_success_margin
    xz_caging = tolerance(tcp_obj_xz, bounds=(0.0, xz_success_margin), margin=xz_margin, sigmoid="long_tail")

    gripper_closed = action[..., 3].clamp(0.0, 1.0)
    caging = hamacher_product(y_caging, xz_caging)
    gripping = torch.where(caging > 0.97, gripper_closed, 0.0)
    caging_and_gripping = hamacher_product(caging, gripping)
    return (caging_and_gripping + caging) / 2.0


def grasped_and_lifted(tcp_to_obj: torch.Tensor, tcp_opened: torch.Tensor, obj_z: torch.Tensor,
                       obj_init_z: torch.Tensor, reach_radius: float) -> torch.Tensor:
    """Meta-World's "object held up" test: TCP within ``reach_radius`` of the object, gripper not fully closed
    (``obs[3] > 0``) and the object more than 1 cm above its initial height. ``[N]`` bool."""
    return (tcp_to_obj < reach_radius) & (tcp_opened > 0) & (obj_z - 0.01 > obj_init_z)
