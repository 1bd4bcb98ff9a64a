"""Scripted window_open: push the sash handle sideways (+x) with the side of the Panda hand.

The hand stays 5.5 cm in front of the handle bar, so that its rear end (10.4 cm behind the TCP along +y) clears the
window frame by ~1.5 cm, and 2 cm below the handle's centre: its underside (3.7 cm above the TCP) is then level with
the upper half of the vertical bar and the upper arm, and the side of the hand (3.2 cm from the TCP in x, ahead of
the fingers) pushes them. Phases, chosen from distances: line up beside the bar well in front of the window (so the
hand never sweeps through the handle), move in to a staging point 6.5 cm beside the bar and, once within 2 cm of
it, push towards the goal (holding y and z) until the handle is 3 mm short of the slide limit.
"""

from __future__ import annotations

import torch

from ._common import action, parse

STAGE_BESIDE = 0.065  # the hand (3.2 cm half-width in x) clears the handle's arms
STAGE_IN_FRONT = 0.055
STAGE_BELOW = 0.02
PRE_IN_FRONT = 0.16  # the hand's rear end stays in front of the handle's arms while lining up
ALIGN_RADIUS = 0.012  # lined up beside the bar before moving in
ENGAGE_RADIUS = 0.02  # push while the hand is this close (in y, z) to the staging point
GAIN = 0.5  # proportional gain of the approach and of the y, z hold (full speed beyond 2 cm)
PUSH_SPEED = 0.6
SHORT_OF_LIMIT = 0.003
GRIP = 1.0  # closed, as Meta-World's policy (the fingers do not touch the handle)


def push_sash(obs: torch.Tensor, direction: float, bar_from_handle: float, handle_end_from_goal: float
              ) -> torch.Tensor:
    """Actions that slide the window sash along ``direction`` (+1: +x) by pushing its handle bar.

    ``bar_from_handle``: x of the bar's axis minus x of the observed handle site; ``handle_end_from_goal``: x of
    the observed handle site at the end of the travel minus the goal's x.
    """
    o = parse(obs)
    hand, handle, goal = o["tcp"], o["obj_pos"], o["goal"]
    bar_x = handle[:, 0] + bar_from_handle
    stage = torch.stack([bar_x - direction * STAGE_BESIDE, handle[:, 1] - STAGE_IN_FRONT,
                         handle[:, 2] - STAGE_BELOW], dim=-1)
    pre = torch.stack([stage[:, 0], handle[:, 1] - PRE_IN_FRONT, stage[:, 2]], dim=-1)
    behind = direction * (hand[:, 0] - bar_x) < -0.03
    yz_error = (hand[:, 1:] - stage[:, 1:]).norm(dim=-1)
    engaged = (yz_error < ENGAGE_RADIUS) & behind
    lined_up = (hand[:, [0, 2]] - stage[:, [0, 2]]).norm(dim=-1) < ALIGN_RADIUS
    approach = torch.where(lined_up[:, None], stage, pre)
    delta_approach = ((approach - hand) * (GAIN / 0.01)).clamp(-1.0, 1.0)
    handle_target = goal[:, 0] + handle_end_from_goal - direction * SHORT_OF_LIMIT
    push_x = ((handle_target - handle[:, 0]) / 0.01).clamp(-PUSH_SPEED, PUSH_SPEED)
    delta_push = torch.cat([push_x[:, None], ((stage[:, 1:] - hand[:, 1:]) * (GAIN / 0.01)).clamp(-1.0, 1.0)],
                           dim=-1)
    delta = torch.where(engaged[:, None], delta_push, delta_approach)
    return action(delta, GRIP)


def policy(obs: torch.Tensor) -> torch.Tensor:
    # handleOpenStart is 2.6 cm left of the bar; the goal is that point at the end of the travel
    return push_sash(obs, +1.0, bar_from_handle=0.026, handle_end_from_goal=0.0)
