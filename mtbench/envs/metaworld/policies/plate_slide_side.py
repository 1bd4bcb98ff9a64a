"""Scripted plate-slide-side: push the plate (-x) into the cabinet with the closed fingertips against its +x edge,
lining it up with the goal in y on the way by friction (see ``_plate.push_plate``).

The cabinet's front crossbar (its opening faces +x; the bar at cabinet x + 0.0685, 15 to 17 cm above the table)
stops the Panda's last link, which reaches 4.4 cm from the TCP along x 10 to 16 cm above it: the TCP stays
``STOP_FROM_CABINET`` or further out, which leaves the plate about 3 cm short of the goal (success radius 5 cm;
the plate slides on a little when the hand stops)."""

from __future__ import annotations

import torch

from ._common import parse
from ._plate import push_plate

CABINET_FROM_GOAL_X = -0.025
STOP_FROM_CABINET = 0.0765 + 0.044 + 0.004  # crossbar's far side + last link's reach + margin
FINGERTIP_X = 0.0088  # closed fingertips' half width along x


def policy(obs: torch.Tensor) -> torch.Tensor:
    goal = parse(obs)["goal"]
    limit = goal[:, 0] + CABINET_FROM_GOAL_X + STOP_FROM_CABINET
    return push_plate(obs, axis=0, sign=-1.0, reach=FINGERTIP_X, limit=limit, lateral=goal[:, 1], grip=1.0)
