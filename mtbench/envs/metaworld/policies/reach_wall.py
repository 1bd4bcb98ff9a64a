"""Scripted reach-wall: fly over the wall at a safe height, then go down onto the goal.

Meta-World's wall spans x in [-0.02, 0.22], y in [0.74, 0.76] and rises to z = 0.12. The Panda hand reaches
10.2 cm either side of the TCP along y, from 3.7 cm above it: with the TCP below ``LOW_Z`` and within the wall's
x range (hand half width 2.5 cm), the TCP must stay 11 cm behind the wall, or the hand's rear end would be in it,
and 11 cm in front of the table's retaining wall (y = 0.98). So the policy aims at the goal moved to that band where
needed (``_wall.clear_of_wall``: at most 3 cm; the success radius is 5 cm) and travels at ``SAFE_Z`` (fingertips
1 cm below the TCP clear the wall top) until it is behind the wall.
"""

from __future__ import annotations

import torch

from ._common import action, move, parse
from ._wall import clear_of_wall

SAFE_Z = 0.16  # TCP height while crossing the wall line (fingertips at ~0.15 > 0.12)
NEAR = 0.015  # y distance to the final line under which the hand may go down


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, goal = o["tcp"], o["goal"]
    final = clear_of_wall(goal)
    over = torch.stack([final[:, 0], final[:, 1], final[:, 2].clamp_min(SAFE_Z)], dim=-1)
    behind = hand[:, 1] > final[:, 1] - NEAR
    target = torch.where(behind[:, None], final, over)
    return action(move(hand, target), 1.0)
