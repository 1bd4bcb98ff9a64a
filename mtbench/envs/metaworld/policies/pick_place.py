"""Scripted pick-place: grasp the puck from above, then carry it through the air onto the goal and hold it there.

The 0.75 kg puck is carried at ``_grasp.PUCK_CARRY_SPEED``: at full speed the Panda's 30 N-per-finger grip can lose it when
the hand changes direction."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_CARRY_SPEED, PUCK_GRASP, grasp_phase, move_lead



def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **PUCK_GRASP)
    target = torch.where(held[:, None], hand + goal - obj, target)  # move the puck (not the hand) to the goal
    delta = move_lead(hand, prev, target, speed=torch.where(held, PUCK_CARRY_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
