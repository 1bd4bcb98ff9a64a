"""Scripted sweep_into_goal: grasp the block on the raised table top, carry it above the hole, lower it into the
hole and hold it there (MTBench's success needs the hand at the block)."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_GRASP, grasp_phase, move_lead, shifted

CARRY_ABOVE_GOAL = 0.06  # block centre height above the goal while travelling (clears the hole's rim)
OVER_HOLE = 0.01  # x-y distance of the block to the goal under which it is lowered
CARRY_SPEED = 1.0


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **PUCK_GRASP)
    over = (obj[:, :2] - goal[:, :2]).norm(dim=-1) < OVER_HOLE
    block_target = torch.where(over[:, None], goal, shifted(goal, dz=CARRY_ABOVE_GOAL))
    target = torch.where(held[:, None], hand + block_target - obj, target)
    delta = move_lead(hand, prev, target, speed=CARRY_SPEED)
    return action(delta, torch.where(close, 1.0, -1.0))
