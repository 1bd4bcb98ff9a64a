"""Scripted handle_pull: pinch the grip bar (along x) with the fingers closing across it, beside the lever arm that
joins the bar's middle, and pull straight up to the top of the travel."""

from __future__ import annotations

import torch

from ._common import parse
from ._handle import pull_up

# the lever arm (6.4 cm wide) joins the middle of the grip bar (14 cm long): grasp 5 cm to its side, at the bar's
# axis (2.2 cm below the observed top of the bar)
GRASP_OFFSET = (0.05, 0.0, -0.022)
HELD_BELOW = 0.6  # openness: open 0.91, closed on the 4.4 cm bar ~0.5


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    return pull_up(o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"], o["gripper_open"], GRASP_OFFSET, HELD_BELOW)
