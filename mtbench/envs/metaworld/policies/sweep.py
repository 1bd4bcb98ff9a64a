"""Scripted sweep: grasp the block from above, carry it just above the table to the goal and hold it there."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_GRASP, grasp_phase, move_lead, shifted

CARRY_LIFT = 0.01  # carry height of the block above its resting height
CARRY_SPEED = 1.0  # the 0.1 kg block stays in the grip at full speed (the goal is up to 50 cm away)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **PUCK_GRASP)
    target = torch.where(held[:, None], hand + shifted(goal, dz=CARRY_LIFT) - obj, target)
    delta = move_lead(hand, prev, target, speed=CARRY_SPEED)
    return action(delta, torch.where(close, 1.0, -1.0))
