"""Scripted push-wall: grasp the puck, carry it just above the table around the wall's left end and onto the goal
behind the wall, and hold it there.

The Panda hand reaches 10.2 cm either side of the TCP along y (see ``_wall``): the puck is grasped with the TCP
at most at ``IN_FRONT_Y`` (the open pads straddle the 4 cm puck up to 2.15 cm off centre and centre it while
closing), carried sideways at that y to ``LANE_X`` beside the wall, forward along that lane until the hand is
behind the wall, then sideways onto the goal, with the TCP between the wall and the table's retaining wall where
the hand overlaps them (``_wall.clear_of_wall``: at most 3 cm from a goal; the success radius is 5 cm)."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import PUCK_GRASP, grasp_phase, holding, move_lead
from ._wall import BEHIND_Y, BESIDE_X, CARRY_SPEED, IN_FRONT_Y, clear_of_wall

CARRY_Z = 0.03  # puck centre while carried (1 cm above its resting height)
LANE_X = BESIDE_X - 0.015  # TCP x while passing the wall
LANE_TOL = 0.012
STAGE_Y = IN_FRONT_Y - 0.01  # y of the sideways move in front of the wall


def _xyz(x: torch.Tensor, y: torch.Tensor | float, z: float) -> torch.Tensor:
    return torch.stack([x, torch.full_like(x, y) if isinstance(y, float) else y, torch.full_like(x, z)], dim=-1)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    grasp_at = torch.stack([obj[:, 0], obj[:, 1].clamp_max(IN_FRONT_Y), obj[:, 2]], dim=-1)
    target, close, _ = grasp_phase(hand, grasp_at, o["gripper_open"], **PUCK_GRASP)
    held = holding(hand, obj, o["gripper_open"], PUCK_GRASP)  # the puck leaves the grasp point while carried
    close = close | held
    # the puck's waypoints (it is held at the TCP)
    behind = obj[:, 1] > BEHIND_Y - 0.01
    in_lane = obj[:, 0] < LANE_X + LANE_TOL
    sideways = _xyz(torch.full_like(obj[:, 0], LANE_X), STAGE_Y, CARRY_Z)
    forward = _xyz(torch.full_like(obj[:, 0], LANE_X), BEHIND_Y + 0.005, CARRY_Z)
    onto_goal = clear_of_wall(torch.stack([goal[:, 0], goal[:, 1], torch.full_like(goal[:, 2], CARRY_Z)], dim=-1))
    obj_target = torch.where(behind[:, None], onto_goal, torch.where(in_lane[:, None], forward, sideways))
    target = torch.where(held[:, None], hand + obj_target - obj, target)
    delta = move_lead(hand, prev, target, speed=torch.where(held, CARRY_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
