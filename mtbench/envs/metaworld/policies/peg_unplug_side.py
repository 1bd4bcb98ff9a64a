"""Scripted peg_unplug_side (MTBench's layout: the plug lies on the table in front of the outlet, along y).

The fingers open along y, the plug's axis, and the plug is longer than the gripper opens, so it cannot be picked up
(see the task's docstring). This controller only does what the hand can: it comes down behind the plug's rear end
with closed fingers and pushes the plug along the table until its head touches the outlet. It does not reach the
success region (the head would have to be lifted to within 5 cm of the hole, 13 cm above the table).
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead

BEHIND = 0.16  # TCP this far behind (-y) the peg head: just behind the plug's rear sphere
PUSH_Z = 0.05  # TCP height while pushing (the hand housing clears the rear sphere's top)
HOVER = 0.08
ALIGNED = 0.01
HEAD_TO_WALL = 0.035  # stop pushing when the head is this far in front of the goal (the head sphere touches)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, head, goal = o["tcp"], o["obj_pos"], o["goal"]
    behind = torch.stack([head[:, 0], head[:, 1] - BEHIND, torch.full_like(head[:, 0], PUSH_Z)], dim=-1)
    aligned = (hand[:, :2] - behind[:, :2]).norm(dim=-1) < ALIGNED
    engaged = ((hand[:, 0] - head[:, 0]).abs() < 0.02) & (hand[:, 2] < PUSH_Z + 0.02) & (hand[:, 1] < head[:, 1])
    above = torch.stack([behind[:, 0], behind[:, 1], behind[:, 2] + HOVER], dim=-1)
    target = torch.where(aligned[:, None], behind, above)
    push_y = goal[:, 1] - HEAD_TO_WALL - BEHIND
    push = torch.stack([head[:, 0], push_y, behind[:, 2]], dim=-1)
    target = torch.where(engaged[:, None], push, target)
    return action(move_lead(hand, o["prev_tcp"], target, 0.6), 1.0)
