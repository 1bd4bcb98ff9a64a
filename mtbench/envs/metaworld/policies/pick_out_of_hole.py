"""Scripted pick-out-of-hole: grasp the cylinder at the bottom of the hole from above, lift it straight up out of
the hole, then carry it to the goal and hold it there.

The hand's underside (3.7 cm above the TCP) stays above the hole's 5.4 cm rim while the pads hold the cylinder at
its centre (z = 0.02); the open fingers fit in the 30 cm hole. The cylinder (10 g) is lifted to ``CLEAR_Z``
before it moves sideways, so that it clears the rim."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import LIGHT_GRASP, grasp_phase, move_lead

CLEAR_Z = 0.12  # cylinder centre height before moving towards the goal (its bottom 2 cm lower, rim at 0.054)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **LIGHT_GRASP)
    lift = torch.stack([obj[:, 0], obj[:, 1], torch.full_like(obj[:, 2], CLEAR_Z)], dim=-1)
    obj_target = torch.where((obj[:, 2] < CLEAR_Z - 0.02)[:, None], lift, goal)
    target = torch.where(held[:, None], hand + obj_target - obj, target)
    return action(move_lead(hand, prev, target), torch.where(close, 1.0, -1.0))
