"""Control shared by the plate-slide policies: drag the plate with the fingertips pressed onto its top
(:func:`drag_plate`), or push it with the fingers against an edge (:func:`push_plate`).

The plate (10 × 10 × 3 cm, 50 g) slides on two joints and cannot move vertically. Closed fingertips pressed onto its
top face (the TCP target ``PRESS_DEPTH`` below the contact height; the fingertip-plate contacts are soft, a few
millimetres deeper and the weld sinks the fingertips into the plate) drag it along by friction in any horizontal
direction; where they press (``press_offset`` from the plate centre) keeps the hand clear of the goal cabinet.
Pushing an edge lets the fingers reach further into the cabinet than the hand above them can go (the Panda's last
link hits the cabinet's front crossbar). Phases, chosen from distances: fly at ``SAFE_Z`` to above the pressing
point (or the point beside the edge), go down, then drag (push). If the plate gets away from the fingers, the hand
rises and comes back.
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead

PLATE_TOP = 0.03
PLATE_HALF_SIZE = 0.05
TIP_BELOW_TCP = 0.009  # closed fingertips' lowest point below the TCP
CONTACT_Z = PLATE_TOP + TIP_BELOW_TCP  # TCP height with the fingertips on the plate
PRESS_DEPTH = 0.003  # the fingertips' contacts with the plate are soft: deeper targets sink them in
SAFE_Z = 0.07  # TCP height while flying over the plate
ALIGN = 0.008  # x-y distance to the pressing point under which the hand goes down
ENGAGED = 0.02  # ... under which a lowered hand counts as pressing
RISE_FIRST = 0.03  # a lowered hand further than this from the pressing point rises before travelling
DRAG_SPEED = 0.6


def _with_z(xy: torch.Tensor, z: float) -> torch.Tensor:
    return torch.cat([xy, torch.full_like(xy[:, :1], z)], dim=-1)


def drag_plate(obs: torch.Tensor, press_offset: tuple[float, float], aim: torch.Tensor) -> torch.Tensor:
    """Actions ``[N, 4]`` that press the closed fingertips onto the plate at ``plate + press_offset`` (x, y) and drag
    it until its centre is at ``aim`` (``[N, 2]``, x-y)."""
    o = parse(obs)
    hand, prev, plate = o["tcp"], o["prev_tcp"], o["obj_pos"]
    press = torch.stack([plate[:, 0] + press_offset[0], plate[:, 1] + press_offset[1]], dim=-1)
    d_xy = (hand[:, :2] - press).norm(dim=-1)
    lowered = hand[:, 2] < CONTACT_Z + 0.004
    engaged = lowered & (d_xy < ENGAGED)
    # not engaged: above the pressing point, then down onto it (rising first if low and far off)
    rise = (d_xy > RISE_FIRST) & (hand[:, 2] < SAFE_Z - 0.02)
    approach = torch.where(rise[:, None], _with_z(hand[:, :2], SAFE_Z), _with_z(press, SAFE_Z))
    approach = torch.where((d_xy < ALIGN)[:, None], _with_z(press, CONTACT_Z - PRESS_DEPTH), approach)
    # engaged: move the hand by the plate's remaining offset, pressing down
    drag = _with_z(hand[:, :2] + aim - plate[:, :2], CONTACT_Z - PRESS_DEPTH)
    target = torch.where(engaged[:, None], drag, approach)
    delta = move_lead(hand, prev, target, speed=torch.where(engaged, DRAG_SPEED, 1.0))
    return action(delta, 1.0)

PUSH_Z = 0.02  # TCP height while pushing an edge: the fingers' lower 2 cm overlap the plate's 3 cm height
BEHIND_GAP = 0.004  # clearance between the fingers and the plate's edge before pushing
EDGE_TOL = 0.008  # x-y distance to the point behind the edge under which the hand goes down


def push_plate(obs: torch.Tensor, axis: int, sign: float, reach: float, limit: torch.Tensor, lateral: torch.Tensor,
               grip: float, speed: float = 1.0) -> torch.Tensor:
    """Actions ``[N, 4]`` that push the plate along world ``axis`` (0: x, 1: y) in direction ``sign`` with the
    fingers against its trailing edge, until the TCP reaches ``limit`` (``[N]``, along ``axis``), while moving the
    plate's other coordinate towards ``lateral`` (``[N]``) by friction.

    ``reach``: how far the fingers reach from the TCP along ``axis`` towards the plate (closed fingertips 0.0088
    along x; open fingers 0.063 along y); ``grip``: the gripper action (+1 closed, -1 open). The fingers go down
    beside the edge from ``SAFE_Z`` and, once there, the hand moves at ``speed`` (at full speed the plate slides
    on a few centimetres when the hand stops).
    """
    o = parse(obs)
    hand, prev, plate = o["tcp"], o["prev_tcp"], o["obj_pos"]
    other = 1 - axis
    gap = PLATE_HALF_SIZE + reach + BEHIND_GAP
    behind = torch.empty_like(plate[:, :2])
    behind[:, axis] = plate[:, axis] - sign * gap
    behind[:, other] = plate[:, other]
    d_xy = (hand[:, :2] - behind).norm(dim=-1)
    # behind the edge (not above the plate), low and roughly centred on it: push
    on_side = sign * (plate[:, axis] - hand[:, axis]) > gap - BEHIND_GAP - 0.002
    engaged = on_side & (hand[:, 2] < PUSH_Z + 0.01) & ((hand[:, other] - plate[:, other]).abs() < 0.02)
    rise = (d_xy > RISE_FIRST) & (hand[:, 2] < SAFE_Z - 0.02)
    approach = torch.where(rise[:, None], _with_z(hand[:, :2], SAFE_Z), _with_z(behind, SAFE_Z))
    approach = torch.where((d_xy < EDGE_TOL)[:, None], _with_z(behind, PUSH_Z), approach)
    push = torch.empty_like(plate[:, :2])
    push[:, axis] = limit
    push[:, other] = hand[:, other] + lateral - plate[:, other]
    target = torch.where(engaged[:, None], _with_z(push, PUSH_Z), approach)
    delta = move_lead(hand, prev, target, speed=torch.where(engaged, speed, 1.0))
    return action(delta, grip)
