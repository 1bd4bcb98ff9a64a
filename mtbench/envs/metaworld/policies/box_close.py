"""Scripted box_close: grasp the lid's handle bar in the middle, lift the lid above the box's walls, carry it over
the box and lower it onto the box, holding it there."""

from __future__ import annotations

import torch

from ...rotations import quat_rotate
from ._common import action, parse
from ._grasp import grasp_phase, move_lead
from ._tools import with_z

BAR_ABOVE_TOP = 0.082  # handle bar axis above the observed top_link, in the lid's frame
BAR_GRASP = dict(above=0.06, xy_tol=0.008, grasp_tol=0.004, hold_tol=0.02,
                 held_below=0.4,  # openness: open 0.91, closed on the 1.6 cm bar ~0.2
                 empty_below=0.08)
CARRY_Z = 0.15  # top_link height while travelling (the skirt clears the 6 cm walls by 7 cm)
CLOSED_Z = 0.062  # top_link of a lid resting on the box: 0.06
OVER_BOX = 0.004
CARRY_SPEED = 0.7
LOWER_SPEED = 0.3


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, top, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    local = torch.zeros_like(top)
    local[:, 2] = BAR_ABOVE_TOP
    bar = top + quat_rotate(o["obj_quat"], local)
    target, close, held = grasp_phase(hand, bar, o["gripper_open"], **BAR_GRASP)
    xy_err = (top[:, :2] - goal[:, :2]).norm(dim=-1)
    over = (xy_err < OVER_BOX) | ((xy_err < 0.01) & (top[:, 2] < CARRY_Z - 0.01))
    high = top[:, 2] > CARRY_Z - 0.02
    lid_target = torch.where(over[:, None], with_z(goal, CLOSED_Z),
                             torch.where(high[:, None], with_z(goal, CARRY_Z), with_z(top, CARRY_Z)))
    target = torch.where(held[:, None], hand + lid_target - top, target)
    speed = torch.where(held, torch.where(over, LOWER_SPEED, CARRY_SPEED), 1.0)
    delta = move_lead(hand, prev, target, speed=speed)
    return action(delta, torch.where(close, 1.0, -1.0))
