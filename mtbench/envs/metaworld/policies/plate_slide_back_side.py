"""Scripted plate-slide-back-side: press the closed fingertips onto the plate's half nearer the cabinet and drag it
sideways (+x), away from the cabinet, to the goal (see ``_plate``)."""

from __future__ import annotations

import torch

from ._common import parse
from ._plate import drag_plate

PRESS_OFFSET = (-0.035, 0.0)


def policy(obs: torch.Tensor) -> torch.Tensor:
    return drag_plate(obs, PRESS_OFFSET, parse(obs)["goal"][:, :2])
