"""Scripted lever_pull: lift the lever's ball with the top edge of the hand.

The Panda's fingers hang below its hand and open along y, the lever's own axis, so they can neither pinch the
lever nor get under it; the hand housing can. Its top face (11.1 cm above the TCP) ends 10.2 cm in front of the TCP
along +y, beyond the wrist, in a free edge. The policy centres the hand on the lever in x, brings that edge up
against the ball from below and behind (the side opposite to its motion), and then moves it along the ball's arc,
``LEAD`` ahead of the lever, until the lever stands upright (the hinge limit stops it). The lever angle follows
from the observed ball and the goal (``goal`` = the ball with the lever upright = hinge + (0, 0, 0.2)).
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead

LEVER_RADIUS = 0.2
BALL_RADIUS = 0.03
EDGE_Y = 0.102  # hand box end beyond the TCP along +y
EDGE_Z = 0.1114  # hand box top above the TCP
BELOW = 0.04  # approach: the edge this far below its pushing point
LEAD = 0.3  # rad
FINAL = 1.75  # rad: the lead target stops here (the hinge limit holds the lever at 1.57)
ENGAGED = 0.04
ALIGNED = 0.025


def _tcp_for_edge(hinge: torch.Tensor, x: torch.Tensor, phi: torch.Tensor) -> torch.Tensor:
    """TCP target that puts the hand's top edge against the ball (lever at ``phi``) on the side opposite to the
    ball's motion."""
    c, s = torch.cos(phi), torch.sin(phi)
    ball_y = hinge[..., 1] - LEVER_RADIUS * c
    ball_z = hinge[..., 2] + LEVER_RADIUS * s
    edge_y = ball_y - BALL_RADIUS * s  # minus the ball radius along the motion direction (0, sin, cos)
    edge_z = ball_z - BALL_RADIUS * c
    return torch.stack([x, edge_y - EDGE_Y, edge_z - EDGE_Z], dim=-1)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, ball, goal = o["tcp"], o["obj_pos"], o["goal"]
    hinge = torch.stack([goal[..., 0], goal[..., 1], goal[..., 2] - LEVER_RADIUS], dim=-1)
    phi = torch.atan2(ball[..., 2] - hinge[..., 2], hinge[..., 1] - ball[..., 1])
    x = ball[..., 0]
    now = _tcp_for_edge(hinge, x, phi)
    lead = _tcp_for_edge(hinge, x, torch.clamp(phi + LEAD, max=FINAL))
    below = torch.stack([now[..., 0], now[..., 1], now[..., 2] - BELOW], dim=-1)
    engaged = (hand - now).norm(dim=-1) < ENGAGED
    under = ((hand[..., :2] - now[..., :2]).norm(dim=-1) < ALIGNED) & (hand[..., 2] < now[..., 2])
    # not engaged: drop to the approach height first (the hand's top must pass under the ball), then slide under
    # the ball, then rise against it
    high = hand[..., 2] > below[..., 2] + 0.02
    drop = torch.stack([hand[..., 0], hand[..., 1], below[..., 2]], dim=-1)
    target = torch.where(high[..., None] & ~under[..., None], drop, below)
    target = torch.where(under[..., None], now, target)
    target = torch.where(engaged[..., None], lead, target)
    return action(move_lead(hand, o["prev_tcp"], target), 1.0)
