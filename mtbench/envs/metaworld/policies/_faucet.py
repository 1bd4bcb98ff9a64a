"""Scripted faucet turning shared by faucet_open and faucet_close: push the handle near its end with the closed
fingers and lead it along its arc.

The hinge follows from the goal (``goal = faucet + (+-0.175, 0, 0.125)``, hinge = ``faucet + (0, 0, 0.124)``), the
handle angle from the observed handle site. The fingers come down beside the handle (on the side away from the
turning direction, clear of its 1.7 cm radius), then the hand target moves along the arc ``LEAD`` ahead of the
handle until the angle reaches ``FINAL``; the hand body stays above the faucet head (its underside is 3.7 cm above
the TCP, the head's top 2 cm above the handle).
"""

from __future__ import annotations

import math

import torch

from ._common import action, move

HANDLE_LENGTH = 0.175
HINGE_HEIGHT = 0.124  # above the faucet base; the goal is 0.125 above it
PUSH_RADIUS = 0.14  # distance of the fingers from the hinge along the handle
SIDE = 0.035  # fingers' offset from the handle axis (handle radius 1.7 cm + finger half thickness 0.9 cm + margin)
HOVER = 0.07  # approach height above the pushing height
ALIGNED = 0.012
ENGAGED = 0.04
LEAD = 0.35  # rad
FINAL = 1.65  # rad: the lead target stops this far from 0 (beyond the 1.57 limit: the limit holds the handle)


def turn(hand: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, sign: float, site_side: float) -> torch.Tensor:
    """Action ``[n, 4]`` turning the handle towards ``sign`` (+1: open, counter-clockwise; -1: close). ``site_side``:
    the observed site's offset across the handle (+0.015 for handleStartClose, -0.015 for handleStartOpen)."""
    hinge = torch.stack([goal[..., 0] - sign * HANDLE_LENGTH, goal[..., 1],
                         goal[..., 2] - 0.125 + HINGE_HEIGHT], dim=-1)
    rel = handle[..., :2] - hinge[..., :2]
    site_phase = math.atan2(-HANDLE_LENGTH, site_side)
    theta = torch.atan2(rel[..., 1], rel[..., 0]) - site_phase
    theta = torch.remainder(theta + math.pi, 2 * math.pi) - math.pi

    def point(angle: torch.Tensor) -> torch.Tensor:
        phi = angle - math.pi / 2  # direction of the handle
        c, s = torch.cos(phi), torch.sin(phi)
        # the fingers sit behind the handle with respect to the turning direction
        x = hinge[..., 0] + PUSH_RADIUS * c + sign * SIDE * s
        y = hinge[..., 1] + PUSH_RADIUS * s - sign * SIDE * c
        return torch.stack([x, y, hinge[..., 2]], dim=-1)

    now = point(theta)
    lead = point(torch.clamp(sign * (theta + sign * LEAD), max=FINAL) * sign)
    dxy = (hand[..., :2] - now[..., :2]).norm(dim=-1)
    low = hand[..., 2] < hinge[..., 2] + 0.02
    engaged = (dxy < ENGAGED) & low
    above = torch.cat([now[..., :2], (now[..., 2] + HOVER)[..., None]], dim=-1)
    target = torch.where((dxy < ALIGNED)[..., None], now, above)
    target = torch.where(engaged[..., None], lead, target)
    return action(move(hand, target), 1.0)
