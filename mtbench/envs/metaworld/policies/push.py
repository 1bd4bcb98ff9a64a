"""Scripted push: grasp the puck from above, then carry it just above the table onto the goal while holding it
(the paper-era MTBench success also needs the hand at the puck, so the puck stays in the closed gripper).

The puck is lifted by ``CARRY_LIFT`` and moved at ``_grasp.PUCK_CARRY_SPEED``: dragging the 0.75 kg puck over the table
(7 N of friction) or moving it at full speed lets it creep out of the Panda's 30 N-per-finger grip."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_CARRY_SPEED, PUCK_GRASP, grasp_phase, move_lead, shifted

CARRY_LIFT = 0.01  # carry height of the puck above its resting height


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **PUCK_GRASP)
    # held: move the puck (not the hand) onto the goal
    target = torch.where(held[:, None], hand + shifted(goal, dz=CARRY_LIFT) - obj, target)
    delta = move_lead(hand, prev, target, speed=torch.where(held, PUCK_CARRY_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
