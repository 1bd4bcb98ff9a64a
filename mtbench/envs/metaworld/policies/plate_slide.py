"""Scripted plate-slide: push the plate (+y) into the cabinet with the open gripper's front finger against its rear
edge, lining it up with the goal in x on the way by friction (see ``_plate.push_plate``).

The cabinet's front crossbar (15 to 17 cm above the table) stops the Panda's last link, which reaches 8.8 cm ahead
of the TCP (+y) 10 to 16 cm above it: the TCP stays ``STOP_FROM_CABINET`` in front of the cabinet centre. The open
front finger reaches 6.3 cm ahead of the TCP (the closed fingertips only 1.5 cm), which leaves the plate about 2 cm
short of the goal (success radius 4.8 cm in x-y; the plate slides on a little when the hand stops)."""

from __future__ import annotations

import torch

from ._common import parse
from ._plate import push_plate

CABINET_FROM_GOAL_Y = 0.025
STOP_FROM_CABINET = 0.0765 + 0.088 + 0.004  # crossbar's far side + last link's reach + margin
OPEN_FINGER_Y = 0.063  # the open front finger's reach ahead of the TCP


def policy(obs: torch.Tensor) -> torch.Tensor:
    goal = parse(obs)["goal"]
    limit = goal[:, 1] + CABINET_FROM_GOAL_Y - STOP_FROM_CABINET
    return push_plate(obs, axis=1, sign=1.0, reach=OPEN_FINGER_Y, limit=limit, lateral=goal[:, 0], grip=-1.0)
