"""Scripted coffee_push: grasp the mug at its centre and slide it forward towards the goal (see ``_mug``).

Success needs the hand at the mug, and the Panda's palm reaches 10.2 cm ahead of the TCP at the height of the
machine's spout (a cylinder of radius 1.6 cm, 14.1 cm in front of the machine's centre): when the goal lies within
4.5 cm of the machine's centre line in x, the palm runs into the spout before the mug gets there. The policy
therefore aims the mug ``SHORT`` in front of the goal and up to ``SIDE`` to the side away from the spout, a point
still inside the success radius (the goal is on the table, 3.5 cm below the observed mug centre, which leaves a
3.4 cm x-y radius). The machine's position follows from the observed button (``button = machine + (0, -0.22,
0.3)``).
"""

from __future__ import annotations

import torch

from ._common import parse
from ._mug import carry_mug

BUTTON_TO_MACHINE_X = 0.0
SPOUT_ZONE = 0.045  # palm half-width (2.5 cm) + spout radius (1.6 cm) + margin
SIDE = 0.02
SHORT = 0.022


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    goal, button = o["goal"], o["obj2_pos"]
    off = goal[:, 0] - (button[:, 0] + BUTTON_TO_MACHINE_X)
    side = torch.where(off >= 0, 1.0, -1.0) * (SPOUT_ZONE - off.abs()).clamp(0.0, SIDE)
    target = torch.stack([goal[:, 0] + side, goal[:, 1] - SHORT], dim=-1)
    return carry_mug(obs, target)
