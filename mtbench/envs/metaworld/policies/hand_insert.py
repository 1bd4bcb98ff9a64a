"""Scripted hand_insert: grasp the block from above, carry it over the hole at a safe height, and lower it onto the
goal point (the hole's floor stops it)."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import grasp_phase, move_lead

GRASP = dict(above=0.06, xy_tol=0.01, grasp_tol=0.008, hold_tol=0.025,
             held_below=0.6,  # openness: open 0.91, closed on the 4 cm block ~0.48
             empty_below=0.3)
CARRY_Z = 0.12  # block height while travelling (the table top is at 0.05)
OVER = 0.01  # x-y distance to the goal under which the block goes down
CARRY_SPEED = 0.7


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, block, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, block, o["gripper_open"], **GRASP)
    over = (block[:, :2] - goal[:, :2]).norm(dim=-1) < OVER
    low = block[:, 2] < CARRY_Z - 0.02
    far = ~over
    z = torch.where(over, goal[:, 2], torch.full_like(goal[:, 2], CARRY_Z))
    xy = torch.where((low & far)[:, None], block[:, :2], goal[:, :2])  # rise before travelling
    desired = torch.cat([xy, z[:, None]], dim=-1)
    carry = hand + (desired - block)
    target = torch.where(held[:, None], carry, target)
    speed = torch.where(held, CARRY_SPEED, 1.0)
    return action(move_lead(hand, prev, target, speed), torch.where(close, 1.0, -1.0))
