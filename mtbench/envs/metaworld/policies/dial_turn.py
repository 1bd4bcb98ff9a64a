"""Scripted dial_turn: turn the dial's bar clockwise (seen from above) with the closed fingertips.

The dial's axis follows from the goal (``goal = axis + (0, -0.03, 0.03)``) and its angle from the observed point
(5 cm from the axis). The fingertips (0.9 cm below the TCP) work at the height of the knob's bar (3.6 .. 6.6 cm above
the table, above the 3.6 cm disc) with the palm (3.7 cm above the TCP) above the bar. Phases, chosen from the
hand's position relative to the bar: fly above a point beside the bar on its counter-clockwise side, go down there,
then push the bar along a circle of radius 3.5 cm, the target leading the bar by ``LEAD`` until the bar is at
``FINAL_TURN`` from its start (success needs 1.81 rad).
"""

from __future__ import annotations

import math

import torch

from ._common import action, parse
from ._grasp import move_lead

AXIS_FROM_GOAL = (0.0, 0.03, -0.03)
START_ANGLE = math.pi / 2  # the observed point starts on the far (+y) side
FINAL_TURN = 2.4  # rad, clockwise
RADIUS = 0.035  # finger path around the axis
CLEAR = 0.9  # rad: angle beside the bar where the fingers go down
CONTACT = 0.45  # rad: angle of the finger's centre beside the bar while pushing (bar half-width + finger)
LEAD = 0.5  # rad: the pushing target leads the contact
HIGH_Z = 0.1  # TCP height while flying (fingertips above the bar's top)
LOW_Z = 0.05  # TCP height while pushing
NEAR = 0.01


def _wrap(a: torch.Tensor) -> torch.Tensor:
    return torch.remainder(a + math.pi, 2 * math.pi) - math.pi


def _on_circle(axis: torch.Tensor, angle: torch.Tensor, z: float) -> torch.Tensor:
    return torch.stack([axis[:, 0] + RADIUS * torch.cos(angle), axis[:, 1] + RADIUS * torch.sin(angle),
                        torch.full_like(angle, z)], dim=-1)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, tip, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    axis = torch.stack([goal[:, 0] + AXIS_FROM_GOAL[0], goal[:, 1] + AXIS_FROM_GOAL[1]], dim=-1)
    bar = torch.atan2(tip[:, 1] - axis[:, 1], tip[:, 0] - axis[:, 0])
    rel = hand[:, :2] - axis
    hand_angle = _wrap(torch.atan2(rel[:, 1], rel[:, 0]) - bar)  # > 0: counter-clockwise of the bar
    low = hand[:, 2] < LOW_Z + 0.015
    beside = (hand_angle > 0.1) & (hand_angle < CLEAR + 0.5) & (rel.norm(dim=-1) < RADIUS + 0.02)

    final = START_ANGLE - FINAL_TURN
    push_angle = torch.maximum(bar - LEAD, bar.new_full(bar.shape, final)) + CONTACT
    push = _on_circle(axis, push_angle, LOW_Z)
    start = _on_circle(axis, bar + CLEAR, LOW_Z)
    above = _on_circle(axis, bar + CLEAR, HIGH_Z)
    over_start = (hand[:, :2] - start[:, :2]).norm(dim=-1) < NEAR
    rise = torch.stack([hand[:, 0], hand[:, 1], torch.full_like(hand[:, 2], HIGH_Z)], dim=-1)
    target = torch.where(over_start[:, None], start, torch.where(low[:, None], rise, above))
    target = torch.where((low & beside)[:, None], push, target)
    return action(move_lead(hand, prev, target), 1.0)
