"""Scripted button-press-topdown: close the fingers, hover above the button, then push it straight down to the end
of its travel (a fixed height relative to the goal, so the hand does not keep shoving the button through its
soft joint limit)."""

from __future__ import annotations

import torch

from ._common import action, move, parse

HOVER = 0.06  # height of the TCP above the button top while aligning in x-y
ALIGNED = 0.012  # x-y distance under which the hand pushes down
# Pushing target of the TCP relative to the goal (the box's hole site): the unpressed button top is 9.35 cm above
# the goal, the button travels 6 cm and the closed fingertips reach 0.94 cm below the TCP, so a TCP at goal + 4.5 cm
# presses the button about 5.8 cm, inside MTBench's success window (5 to 7 cm) and short of the depth (about 7 cm)
# where the button's collar wedges in the box opening.
PRESS_ABOVE_GOAL = 0.045
PRESS_SPEED = 0.5  # slower descent while pressing: less overshoot of the weld-driven hand


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, button, goal = o["tcp"], o["obj_pos"], o["goal"]
    aligned = (hand[..., :2] - button[..., :2]).norm(dim=-1) <= ALIGNED
    z = torch.where(aligned, goal[..., 2] + PRESS_ABOVE_GOAL, button[..., 2] + HOVER)
    target = torch.cat([button[..., :2], z[..., None]], dim=-1)
    delta = move(hand, target)
    dz = torch.where(aligned, delta[..., 2].clamp(-PRESS_SPEED, PRESS_SPEED), delta[..., 2])
    return action(torch.cat([delta[..., :2], dz[..., None]], dim=-1), 1.0)
