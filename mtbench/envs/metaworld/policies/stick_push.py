"""Scripted stick_push: grasp the stick in its middle, lift it to the thermos' mid height in line with the
thermos' axis, then push the thermos to the right (+x) with the stick's end and hold it there."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_GRASP, grasp_phase, move_lead

STICK_HALF_LENGTH = 0.1
THERMOS_RADIUS = 0.06
PUSH_Z = 0.1  # stick height while pushing (the thermos' body spans 0.04..0.24)
STAGE_GAP = 0.03  # the stick's end stops this far left of the thermos while lining up
LINED_UP = 0.008  # y and z error under which the push starts
PUSH_PAST_GOAL = -0.04  # push the thermos' axis to goal_x + this (success: within 10 cm of the goal)
PUSH_SPEED = 0.5


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, stick, thermos, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["obj2_pos"], o["goal"]
    target, close, held = grasp_phase(hand, stick, o["gripper_open"], **PUCK_GRASP)
    contact_x = thermos[:, 0] - THERMOS_RADIUS - STICK_HALF_LENGTH  # stick centre x with its end touching
    lined_up = ((stick[:, 1] - thermos[:, 1]).abs() < LINED_UP) & ((stick[:, 2] - PUSH_Z).abs() < LINED_UP)
    stage_x = torch.minimum(stick[:, 0], contact_x - STAGE_GAP)
    stage = torch.stack([stage_x, thermos[:, 1], torch.full_like(stage_x, PUSH_Z)], dim=-1)
    push_x = goal[:, 0] + PUSH_PAST_GOAL - THERMOS_RADIUS - STICK_HALF_LENGTH
    push = torch.stack([push_x, thermos[:, 1], torch.full_like(push_x, PUSH_Z)], dim=-1)
    stick_target = torch.where(lined_up[:, None], push, stage)
    target = torch.where(held[:, None], hand + stick_target - stick, target)
    delta = move_lead(hand, prev, target, speed=torch.where(held & lined_up, PUSH_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
