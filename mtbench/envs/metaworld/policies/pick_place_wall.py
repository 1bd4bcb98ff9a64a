"""Scripted pick-place-wall: grasp the puck, lift it in front of the wall, carry it over the wall and lower it
onto the goal, then hold it there.

The Panda hand reaches 10.2 cm either side of the TCP along y (see ``_wall``): the puck is grasped with the TCP
at most at ``IN_FRONT_Y`` (the open pads straddle the 4 cm puck up to 2.15 cm off centre and centre it while
closing) and lifted there to ``OVER_Z`` (its bottom 2.5 cm above the wall) before it moves towards the goal; it
is lowered only once above the goal, with the TCP between the wall and the table's retaining wall where the hand
would otherwise overlap them (``_wall.clear_of_wall``: at most 3 cm from a goal; the success radius is 5 cm)."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_GRASP, grasp_phase, holding, move_lead
from ._wall import CARRY_SPEED, IN_FRONT_Y, WALL_TOP_Z, clear_of_wall

OVER_Z = WALL_TOP_Z + 0.045  # puck centre while crossing the wall (bottom 2.5 cm above it)
STAGE_Y = IN_FRONT_Y - 0.01  # y of the puck while it is lifted
LIFTED = 0.015  # the puck moves on once this close to the crossing height
ABOVE_GOAL = 0.015  # x-y distance to the goal under which the puck goes down (or up) to it


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    grasp_at = torch.stack([obj[:, 0], obj[:, 1].clamp_max(IN_FRONT_Y), obj[:, 2]], dim=-1)
    target, close, _ = grasp_phase(hand, grasp_at, o["gripper_open"], **PUCK_GRASP)
    held = holding(hand, obj, o["gripper_open"], PUCK_GRASP)  # the puck leaves the grasp point while carried
    close = close | held
    # the puck's waypoints (it is held at the TCP)
    final = clear_of_wall(goal)
    travel_z = final[:, 2].clamp_min(OVER_Z)
    lift = torch.stack([final[:, 0], obj[:, 1].clamp_max(STAGE_Y), travel_z], dim=-1)
    over = torch.stack([final[:, 0], final[:, 1], travel_z], dim=-1)
    low = (obj[:, 2] < OVER_Z - LIFTED) & (obj[:, 1] < IN_FRONT_Y + 0.02)
    above = (obj[:, :2] - final[:, :2]).norm(dim=-1) < ABOVE_GOAL
    obj_target = torch.where(above[:, None], final, torch.where(low[:, None], lift, over))
    target = torch.where(held[:, None], hand + obj_target - obj, target)
    delta = move_lead(hand, prev, target, speed=torch.where(held, CARRY_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
