"""Scripted handle_pull_side: the grip bar lies along y, the axis along which the fingers open, so pinch the lever
arm (6.4 cm wide in y) just inside the bar and pull straight up to the top of the travel."""

from __future__ import annotations

import torch

from ._common import parse
from ._handle import pull_up

# lever arm centre line: 7 cm before the observed top of the grip bar along -x, 2.2 cm lower
GRASP_OFFSET = (-0.07, 0.0, -0.022)
HELD_BELOW = 0.8  # openness: open 0.91, closed on the 6.4 cm arm ~0.7


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    return pull_up(o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"], o["gripper_open"], GRASP_OFFSET, HELD_BELOW)
