"""Scripted door_unlock: swing the hanging lock lever up by pushing it sideways (+x) with the side of the palm.

As for door_lock, only the palm can reach the lever (1.3 cm in front of the door): with the TCP 23 cm in front of
the safe's origin the palm (5 cm wide in x, 10.2 cm ahead of the TCP) spans the lever's depth, 6 mm in front of the
lock's base. The palm's underside is 1 cm below the hanging lever's end, so its +x face meets the whole lower
part of the lever; pushed along +x, the lever turns up about its hinge (the contact stays below the hinge, so the
push keeps turning it) until the palm's face is 6.5 cm past the hinge (success needs the lever within about 0.37 rad
of horizontal). Phases: line up beside the lever (on its -x side) at the pushing height, then push.
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead

HINGE_FROM_GOAL = (-0.1, 0.04, 0.0)
SAFE_FROM_HINGE_Y = 0.118
TCP_FROM_SAFE_Y = -0.23
PALM_HALF_X = 0.025
PALM_BELOW_TCP = 0.0367
LEVER_LOW = -0.102  # the palm's underside below the hinge (the hanging lever ends 9.2 cm below it)
START_X = -0.05  # the palm's +x face before the push, relative to the hinge (the lever is 1 cm thick)
PUSH_X = 0.09  # the palm's +x face at the end of the push, relative to the hinge
ALIGN_TOL = 0.01
PUSH_SPEED = 0.5


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, goal = o["tcp"], o["prev_tcp"], o["goal"]
    hinge = torch.stack([goal[:, i] + HINGE_FROM_GOAL[i] for i in range(3)], dim=-1)
    y = hinge[:, 1] + SAFE_FROM_HINGE_Y + TCP_FROM_SAFE_Y
    z = hinge[:, 2] + LEVER_LOW - PALM_BELOW_TCP
    start = torch.stack([hinge[:, 0] + START_X - PALM_HALF_X, y, z], dim=-1)
    push = torch.stack([hinge[:, 0] + PUSH_X - PALM_HALF_X, y, z], dim=-1)
    # push once lined up at the pushing height in y and z and not to the +x side of the start line by much
    lined_up = ((hand[:, 1] - y).abs() < ALIGN_TOL) & ((hand[:, 2] - z).abs() < ALIGN_TOL)
    started = lined_up & (hand[:, 0] > start[:, 0] - ALIGN_TOL)
    # before that: go over to the start point at a safe height (above the lever's top), then down
    high = torch.stack([start[:, 0], y, hinge[:, 2] + 0.05], dim=-1)
    over = (hand[:, :2] - start[:, :2]).norm(dim=-1) < ALIGN_TOL
    target = torch.where(over[:, None], start, high)
    target = torch.where(started[:, None], push, target)
    return action(move_lead(hand, prev, target, speed=torch.where(started, PUSH_SPEED, 1.0)), 1.0)
