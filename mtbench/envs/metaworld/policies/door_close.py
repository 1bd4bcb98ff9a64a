"""Scripted door_close: push the open door shut along its arc with the closed fingertips, the palm above the door.

The hinge follows from the goal (``goal = safe + (0.15, -0.16, 0)``, hinge = ``safe + (-0.185, -0.1, 0)``) and the
door angle from the observed handle point (``hinge + R(angle) (0.325, -0.062)``). The door's outer face (the handle
side: -x when open, -y when closed) is pushed 25 cm from the hinge. The TCP stays at 0.268: the palm (3.7 cm above
the TCP) then clears the door's top (0.273) and the safe's top (0.30) and the fingertips (0.9 cm below the TCP)
overlap the door's top 1.5 cm; they pass above the handle (below 0.173). Phases, chosen from the hand's position in
the door's frame: go to a point 8 cm outside the door's face, then push along the arc with the target leading the
door by ``LEAD`` until the door is closed.
"""

from __future__ import annotations

import math

import torch

from ._common import action, parse
from ._grasp import move_lead

HINGE_FROM_GOAL = (-0.335, 0.06)
HANDLE_ON_DOOR = (0.325, -0.062)
HANDLE_PHASE = math.atan2(HANDLE_ON_DOOR[1], HANDLE_ON_DOOR[0])
PUSH_RADIUS = 0.25  # along the door from the hinge
HALF_THICKNESS = 0.01  # the door panel's half thickness
FINGER_HALF = (0.0095, 0.0183)  # closed fingers' half extent in x and y (their tapered middle section)
PRESS = 0.01  # the pushing target lies this far inside the face
STAND_OFF = 0.08  # approach point outside the face
PUSH_Z = 0.268
LEAD = 0.3  # rad
CLOSED = 0.02  # rad: the pushing target's final door angle (the hinge stops at 0)
NEAR = 0.015


def _door_point(hinge: torch.Tensor, angle: torch.Tensor, along: float, normal: torch.Tensor | float) -> torch.Tensor:
    """``hinge + R(angle) (along, -normal)`` at the pushing height (``normal > 0``: outside the face)."""
    c, s = torch.cos(angle), torch.sin(angle)
    x = hinge[:, 0] + along * c + normal * s
    y = hinge[:, 1] + along * s - normal * c
    return torch.stack([x, y, torch.full_like(x, PUSH_Z)], dim=-1)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, handle, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    hinge = torch.stack([goal[:, 0] + HINGE_FROM_GOAL[0], goal[:, 1] + HINGE_FROM_GOAL[1]], dim=-1)
    rel = handle[:, :2] - hinge
    angle = torch.atan2(rel[:, 1], rel[:, 0]) - HANDLE_PHASE  # 0 closed, -pi/2 open

    # hand in the door's frame: along the door and outwards from its mid-plane
    hr = hand[:, :2] - hinge
    c, s = torch.cos(angle), torch.sin(angle)
    along = hr[:, 0] * c + hr[:, 1] * s
    out = hr[:, 0] * s - hr[:, 1] * c
    engaged = ((out > HALF_THICKNESS) & (out < STAND_OFF + NEAR) & (along > 0.15) & (along < 0.36)
               & ((hand[:, 2] - PUSH_Z).abs() < 0.02))

    lead = torch.clamp(angle + LEAD, max=CLOSED)
    extent = FINGER_HALF[0] * torch.sin(lead).abs() + FINGER_HALF[1] * torch.cos(lead).abs()
    push = _door_point(hinge, lead, PUSH_RADIUS, HALF_THICKNESS + extent - PRESS)
    approach = _door_point(hinge, angle, PUSH_RADIUS, STAND_OFF)
    at_approach = (hand - approach).norm(dim=-1) < NEAR
    target = torch.where((engaged & (at_approach | (out < STAND_OFF - NEAR)))[:, None], push, approach)
    return action(move_lead(hand, prev, target), 1.0)
