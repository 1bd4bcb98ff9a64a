"""Scripted push-back: grasp the block from above, then carry it just above the table back (-y) onto the goal
and hold it there (as the push policy does with its puck).

The 4 cm block is as wide as push's puck, so the puck grasp parameters apply; it is carried 1 cm above the table
at ``_grasp.PUCK_CARRY_SPEED`` (0.75 kg: dragging it over the table or moving it at full speed lets it creep out
of the grip)."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_CARRY_SPEED, PUCK_GRASP, grasp_phase, move_lead, shifted

CARRY_LIFT = 0.01  # carry height of the block above its resting height


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **PUCK_GRASP)
    target = torch.where(held[:, None], hand + shifted(goal, dz=CARRY_LIFT) - obj, target)
    delta = move_lead(hand, prev, target, speed=torch.where(held, PUCK_CARRY_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
