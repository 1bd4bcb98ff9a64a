"""Scripted drawer_open: hook the open rear finger's tip over the back of the handle bar and drag the drawer out.

The Panda hand cannot get a finger fully behind the bar of the closed drawer: the hand body (10.4 cm either side
of the TCP along the finger axis, its underside 3.7 cm above the TCP) meets the drawer's front wall first. So the
policy keeps the gripper open and lowers the rear (+y) finger onto the bar from above with the TCP 4.8 cm in front
of the bar's axis: the fingertip comes down on the bar's upper rear side while the end of the hand rests against
the front wall, and the contact on the back of the round bar (plus friction) drags the drawer when the hand moves
to -y. Phases, chosen from distances: fly at a safe height to that point, descend (slowly for the last 3 cm), then
pull at a limited speed until the handle is 0.5 cm short of the goal (the fully open handle point). If the finger slips off the bar, the hand is no longer aligned and climbs back to
re-approach.
"""

from __future__ import annotations

import torch

from ._common import action, parse

BAR_FROM_HANDLE = 0.01  # the observed handle point is 1 cm in front (-y) of the bar's axis
BAR_RADIUS = 0.009
FINGERTIP_BELOW_TCP = 0.0094
REAR_FINGER_OFFSET = 0.048  # TCP this far in front of the bar's axis puts the open rear finger's tip on it
PRESS_DEPTH = 0.02  # TCP target this far below first contact: the weld keeps the finger pressed on the bar
SAFE_HEIGHT = 0.07  # above contact: the hand clears the cabinet top
ALIGN_RADIUS = 0.012
RISE_RADIUS = 0.03
SLOW_ZONE = 0.03
DESCENT_SPEED = 0.3
PULL_SPEED = 0.5
OPEN_SHORT_OF_GOAL = 0.005


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, handle, goal = o["tcp"], o["obj_pos"], o["goal"]
    bar_y = handle[:, 1] + BAR_FROM_HANDLE
    contact_z = handle[:, 2] + BAR_RADIUS + FINGERTIP_BELOW_TCP
    press = torch.stack([handle[:, 0], bar_y - REAR_FINGER_OFFSET, contact_z - PRESS_DEPTH], dim=-1)
    safe_z = contact_z + SAFE_HEIGHT
    dxy = (hand[:, :2] - press[:, :2]).norm(dim=-1)
    aligned = dxy < ALIGN_RADIUS
    touching = hand[:, 2] < contact_z + 0.003

    # not aligned: fly to the pressing point at the safe height (climb first if low and far off)
    far = torch.stack([press[:, 0], press[:, 1], safe_z], dim=-1)
    rise = (dxy > RISE_RADIUS) & (hand[:, 2] < safe_z - 0.02)
    far = torch.where(rise[:, None], torch.cat([hand[:, :2], safe_z[:, None]], dim=-1), far)
    delta_far = ((far - hand) / 0.01).clamp(-1.0, 1.0)

    # aligned: descend onto the bar, then pull while pressing
    delta_near = ((press - hand) / 0.01).clamp(-1.0, 1.0)
    pull = ((goal[:, 1] + OPEN_SHORT_OF_GOAL - handle[:, 1]) / 0.01).clamp(-PULL_SPEED, PULL_SPEED)
    near_y = torch.where(touching, pull, delta_near[:, 1])
    slow = hand[:, 2] < contact_z + SLOW_ZONE
    near_z = torch.where(slow, delta_near[:, 2].clamp(min=-DESCENT_SPEED), delta_near[:, 2])
    delta_near = torch.stack([delta_near[:, 0], near_y, near_z], dim=-1)

    delta = torch.where(aligned[:, None], delta_near, delta_far)
    return action(delta, -1.0)
