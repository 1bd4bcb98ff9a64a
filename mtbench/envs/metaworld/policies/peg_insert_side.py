"""Scripted peg-insert-side: grasp the peg on its centre line at the grasp point, lift it onto the axis of the
hole (keeping x), then slide it head first into the hole and hold it there."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import grasp_phase, move_lead, shifted

GRASP = dict(above=0.06, xy_tol=0.01, grasp_tol=0.005, hold_tol=0.025,
             held_below=0.6,  # openness: open 0.91, closed on the 3 cm peg ~0.38
             empty_below=0.2)  # openness below which the gripper closed on nothing
GRASP_ABOVE_CENTRE = 0.01  # the observed peg point (``pegGrasp`` site) is 1 cm above the peg's centre line
HEAD_FROM_GRASP = (-0.13, 0.0, -0.01)  # peg head relative to ``pegGrasp``
LINE_UP_TOL = 0.006  # y/z error to the hole axis below which the peg moves in


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, peg, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, shifted(peg, dz=-GRASP_ABOVE_CENTRE), o["gripper_open"], **GRASP)
    # held: where the observed peg point must go for the head to reach the goal
    inserted = shifted(goal, *(-d for d in HEAD_FROM_GRASP))
    lined_up = ((peg[:, 1:] - inserted[:, 1:]).abs() < LINE_UP_TOL).all(dim=-1)
    line_up = torch.cat([peg[:, :1], inserted[:, 1:]], dim=-1)  # onto the hole's axis first, keeping x
    peg_target = torch.where(lined_up[:, None], inserted, line_up)
    target = torch.where(held[:, None], hand + peg_target - peg, target)
    delta = move_lead(hand, prev, target)
    return action(delta, torch.where(close, 1.0, -1.0))
