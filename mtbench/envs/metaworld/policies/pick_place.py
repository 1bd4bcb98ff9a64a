"""Scripted pick-place: grasp the puck from above, then carry it through the air onto the goal and hold it there.

The 0.75 kg puck is carried at ``CARRY_SPEED``: at full speed the Panda's 30 N-per-finger grip can lose it when
the hand changes direction."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import grasp_phase, move_lead

CARRY_SPEED = 0.5  # |action| per axis while carrying
GRASP = dict(above=0.06, xy_tol=0.01, grasp_tol=0.005, hold_tol=0.025,
             held_below=0.6,  # openness: open 0.91, closed on the 4 cm puck ~0.48
             empty_below=0.3)  # openness below which the gripper closed on nothing


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["hand"], obs[..., 18:21], o["obj"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper"], **GRASP)
    target = torch.where(held[:, None], hand + goal - obj, target)  # move the puck (not the hand) to the goal
    delta = move_lead(hand, prev, target, speed=torch.where(held, CARRY_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
