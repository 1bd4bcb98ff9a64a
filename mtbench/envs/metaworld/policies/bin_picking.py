"""Scripted bin_picking: grasp the cube in the red bin from above (fingers only partly open: the cube can lie
next to a bin wall), lift it over the bin walls, carry it above the
blue bin and lower it onto the goal (the bin's centre, 5 cm above the table), holding it there."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_GRASP, grasp_phase, move_lead
from ._tools import preshaped_grip

CARRY_Z = 0.13  # cube centre height while travelling (the bin walls end at 0.06)
OVER_GOAL = 0.01  # x-y distance under which the cube is lowered
CARRY_SPEED = 1.0
PRESHAPE = 0.66  # openness on the way down: 6.6 cm between the pads, clear of the bin walls around the 4 cm cube


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **PUCK_GRASP)
    over = (obj[:, :2] - goal[:, :2]).norm(dim=-1) < OVER_GOAL
    high = (obj[:, 2] > CARRY_Z - 0.02) | over
    lift = torch.cat([obj[:, :2], torch.full_like(obj[:, :1], CARRY_Z)], dim=-1)
    travel = torch.cat([goal[:, :2], torch.full_like(obj[:, :1], CARRY_Z)], dim=-1)
    cube_target = torch.where(over[:, None], goal, torch.where(high[:, None], travel, lift))
    target = torch.where(held[:, None], hand + cube_target - obj, target)
    delta = move_lead(hand, prev, target, speed=CARRY_SPEED)
    return action(delta, preshaped_grip(o["gripper_open"], close, PRESHAPE))
