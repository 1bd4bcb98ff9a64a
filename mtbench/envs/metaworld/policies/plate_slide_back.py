"""Scripted plate-slide-back: press the closed fingertips onto the plate's near half and drag it back (-y) to the
goal (see ``_plate``). Pressing on the near half keeps the hand (10.2 cm either side of the TCP along y) in front of
the cabinet's posts, 3 cm behind the plate."""

from __future__ import annotations

import torch

from ._common import parse
from ._plate import drag_plate

PRESS_OFFSET = (0.0, -0.035)  # the hand's front end 1 cm short of the posts at the start


def policy(obs: torch.Tensor) -> torch.Tensor:
    return drag_plate(obs, PRESS_OFFSET, parse(obs)["goal"][:, :2])
