"""Scripted door_lock: press the lock lever down with the underside of the Panda's palm.

The lever sticks out of the door 1.3 cm in front of its face, so neither the closed fingers (in front of the lever
when the palm, 10.2 cm ahead of the TCP, must stay in front of the lock's base) nor the open ones (whose far
fingertip would overlap the lever by 3 mm) can push it. The palm's underside can: with the TCP 23 cm in front of
the safe's origin the palm spans the lever's depth and stays 6 mm in front of the lock's base, and the fingers hang
below it in front of the lever (clear of the door handle, which is further to +x). The hinge follows from the goal
(``goal = hinge + (0, -0.04, -0.1)``); the palm (5 cm wide in x) is centred 5.5 cm along the lever, where it covers
the lever's end from horizontal down to about 75 degrees. Phases: line up above the lever, then press down until
the palm is 9 cm below the hinge (success needs about 1.2 rad).
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead

HINGE_FROM_GOAL = (0.0, 0.04, 0.1)
SAFE_FROM_HINGE_Y = 0.118
TCP_FROM_SAFE_Y = -0.23
PALM_ALONG_LEVER = 0.055
PALM_BELOW_TCP = 0.0367  # the palm's underside is this far above the TCP
ABOVE = 0.04  # the palm's underside above the hinge while lining up (lever top: hinge + 0.01)
PRESS_TO = -0.09  # the palm's underside below the hinge at the end of the press
ALIGN_TOL = 0.01
PRESS_SPEED = 0.5


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, goal = o["tcp"], o["prev_tcp"], o["goal"]
    hinge = torch.stack([goal[:, i] + HINGE_FROM_GOAL[i] for i in range(3)], dim=-1)
    x = hinge[:, 0] + PALM_ALONG_LEVER
    y = hinge[:, 1] + SAFE_FROM_HINGE_Y + TCP_FROM_SAFE_Y
    aligned = ((hand[:, 0] - x).abs() < ALIGN_TOL) & ((hand[:, 1] - y).abs() < ALIGN_TOL)
    z = torch.where(aligned, hinge[:, 2] + PRESS_TO, hinge[:, 2] + ABOVE) - PALM_BELOW_TCP
    target = torch.stack([x, y, z], dim=-1)
    return action(move_lead(hand, prev, target, speed=torch.where(aligned, PRESS_SPEED, 1.0)), 1.0)
