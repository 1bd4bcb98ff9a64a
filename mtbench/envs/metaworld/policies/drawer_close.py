"""Scripted drawer_close: push the open drawer's front wall shut with the closed fingers.

The TCP stays 5 cm above the handle bar: the closed fingers (5.3 cm long along y, reaching 0.9 cm below the TCP)
then pass over the bar and overlap the drawer's front wall (top 6 cm above the bar) by ~2 cm, and the hand body
(3.7 cm above the TCP) clears the cabinet top, so nothing but the fingers touches the drawer. The fingers
stop against the cabinet front exactly when the drawer is closed. Phases, chosen from distances: fly at a safe
height to a point above the bar, descend, then push along +y at a limited speed.
"""

from __future__ import annotations

import torch

from ._common import action, parse

# observed handle point = bar axis + (0, -0.01, 0.05); the goal is that point with the drawer closed
HANDLE_TO_BAR = (0.0, 0.01, -0.05)
PUSH_HEIGHT = 0.05  # TCP above the bar axis while pushing
SAFE_HEIGHT = 0.1  # TCP above the bar axis while flying in
FRONT_WALL_FROM_BAR = 0.06  # the front wall's outer face is 6 cm behind (+y) the bar axis
FINGER_FRONT = 0.0263  # closed fingers reach this far ahead (+y) of the TCP
ALIGN_RADIUS = 0.015
PUSH_SPEED = 0.8


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, handle, goal = o["tcp"], o["obj_pos"], o["goal"]
    bar = torch.stack([handle[:, 0] + HANDLE_TO_BAR[0], handle[:, 1] + HANDLE_TO_BAR[1],
                       handle[:, 2] + HANDLE_TO_BAR[2]], dim=-1)
    stage = torch.stack([bar[:, 0], bar[:, 1], bar[:, 2] + PUSH_HEIGHT], dim=-1)
    in_front = hand[:, 1] < bar[:, 1] + FRONT_WALL_FROM_BAR - FINGER_FRONT + 0.01
    xz_ok = (hand[:, [0, 2]] - stage[:, [0, 2]]).norm(dim=-1) < ALIGN_RADIUS
    xy_ok = (hand[:, :2] - stage[:, :2]).norm(dim=-1) < ALIGN_RADIUS

    # push until the fingers' front reaches the closed wall (2 mm short; the cabinet front stops them there)
    push_y = goal[:, 1] + HANDLE_TO_BAR[1] + FRONT_WALL_FROM_BAR - FINGER_FRONT - 0.002
    push = torch.stack([stage[:, 0], push_y, stage[:, 2]], dim=-1)
    high = torch.stack([stage[:, 0], stage[:, 1], bar[:, 2] + SAFE_HEIGHT], dim=-1)
    target = torch.where((in_front & xz_ok)[:, None], push, torch.where((in_front & xy_ok)[:, None], stage, high))
    delta = ((target - hand) / 0.01).clamp(-1.0, 1.0)
    delta[:, 1] = torch.where(in_front & xz_ok, delta[:, 1].clamp(-PUSH_SPEED, PUSH_SPEED), delta[:, 1])
    return action(delta, 1.0)
