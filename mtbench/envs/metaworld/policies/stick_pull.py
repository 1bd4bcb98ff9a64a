"""Scripted stick_pull: grasp the stick, shove the thermos to the right (+x) with the stick's end if it is far
short of the goal in x, then hook the stick through the thermos' handle and drag the thermos towards the robot
(-y) to the goal's y.

The thermos slides on joints that carry its weight, so nothing but its joint damping slows it down: a shove sends
it to the end of its x slide (20 cm), which, given MTBench's ranges, leaves it within 10 cm of the goal in x
whenever it started more than 10 cm short (otherwise it is not shoved). Pulling through the handle only moves it
in y, and there the stick inside the handle's opening stops it again. The stick lies in line with the thermos (MTBench
places the thermos 30 cm to its right); the handle's opening (between the thermos body at y = -0.06 and the
handle bar at y = -0.13 from its axis) is centred on the observed ``insertion`` point. The stick is held 1.5 cm
left of its centre (MTBench's grasp test allows 3 cm), which keeps the 20 cm long palm clear of the thermos body
when the stick's end reaches the handle.
"""

from __future__ import annotations

import torch

from ...rotations import quat_rotate
from ._common import action, parse
from ._grasp import PUCK_GRASP, grasp_phase, move_lead, shifted

STICK_HALF_LENGTH = 0.1
THERMOS_RADIUS = 0.06
HANDLE_FROM_INSERTION = (0.0, 0.0, -0.022)  # MTBench's handle point relative to the observed insertion site
AXIS_FROM_INSERTION = 0.09  # the thermos axis is 9 cm behind (+y) the insertion point
GRIP_BACK = 0.015  # grasp the stick this far left of its centre
STICK_Z = 0.11  # stick height while hooking (the handle point's height)
SHOVE_Z = 0.05  # stick height while shoving (its end meets the thermos' base and body)
SHOVE_BELOW = 0.1  # shove the thermos while it is more than this short of the goal in x
GAP = 0.03  # the stick's end waits this far left of the body / handle while lining up
LINED_UP = 0.008
INSERT_DEPTH = 0.015  # the end goes this far past the handle point
OPENING_BELOW, OPENING_ABOVE = 0.03, 0.015  # stick-centre y band (from the handle point) inside the opening
SHOVE_SPEED = 1.0
PULL_SPEED = 0.8


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, stick, insertion, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["obj2_pos"], o["goal"]
    axis = torch.zeros_like(stick)
    axis[:, 0] = 1.0
    axis = quat_rotate(o["obj_quat"], axis)
    target, close, held = grasp_phase(hand, stick - GRIP_BACK * axis, o["gripper_open"], **PUCK_GRASP)
    end = stick + STICK_HALF_LENGTH * axis
    handle = shifted(insertion, *HANDLE_FROM_INSERTION)

    def at(x: torch.Tensor, y: torch.Tensor, height: float = STICK_Z) -> torch.Tensor:
        return torch.stack([x, y, torch.full_like(x, height)], dim=-1)

    def lined_up(y: torch.Tensor, height: float = STICK_Z) -> torch.Tensor:
        return ((stick[:, 1] - y).abs() < LINED_UP) & ((stick[:, 2] - height).abs() < LINED_UP)

    # shove: the stick in line with the thermos axis, its end driven into the body
    thermos_y = insertion[:, 1] + AXIS_FROM_INSERTION
    shove = handle[:, 0] < goal[:, 0] - SHOVE_BELOW
    in_line = lined_up(thermos_y, SHOVE_Z)
    left_of_body = torch.minimum(stick[:, 0], handle[:, 0] - THERMOS_RADIUS - GAP - STICK_HALF_LENGTH)
    shove_target = torch.where(in_line[:, None], at(goal[:, 0] - STICK_HALF_LENGTH, thermos_y, SHOVE_Z),
                               at(left_of_body, thermos_y, SHOVE_Z))

    # hook: line up with the opening left of the handle, insert the end, pull the handle to the goal's y
    at_opening = lined_up(handle[:, 1])
    # in the opening: the stick's centre within the opening's band around the handle point's y, its end past the
    # near arm
    dy = stick[:, 1] - handle[:, 1]
    inserted = ((dy > -OPENING_BELOW) & (dy < OPENING_ABOVE) & ((stick[:, 2] - STICK_Z).abs() < 0.015)
                & (end[:, 0] >= handle[:, 0] - 0.01))
    insert_x = handle[:, 0] + INSERT_DEPTH - STICK_HALF_LENGTH
    left_of_handle = torch.minimum(stick[:, 0], handle[:, 0] - GAP - STICK_HALF_LENGTH)
    pull = at(insert_x, stick[:, 1] + goal[:, 1] - handle[:, 1] - 0.005)
    hook_target = torch.where(inserted[:, None], pull,
                              torch.where(at_opening[:, None], at(insert_x, handle[:, 1]),
                                          at(left_of_handle, handle[:, 1])))

    stick_target = torch.where(shove[:, None], shove_target, hook_target)
    target = torch.where(held[:, None], hand + stick_target - stick, target)
    speed = torch.where(held & shove & in_line, SHOVE_SPEED, torch.where(held & inserted, PULL_SPEED, 1.0))
    delta = move_lead(hand, prev, target, speed=speed)
    return action(delta, torch.where(close, 1.0, -1.0))
