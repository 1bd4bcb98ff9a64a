"""Scripted door-open for the Panda (hand pointing down, fingers opening along world y).

Meta-World's Sawyer policy puts the closed fingers between the handle bar and the door panel. The Panda's palm is
20 cm long along the finger axis, so with the fingers there it would hit the panel. Instead:

* Phase A (door angle above ``SWITCH_ANGLE``): straddle the handle bar with the *open* fingers, the palm in front of
  the bar (clear of the panel), so that the far finger sits between bar and panel; then move the hand along the
  door's arc ahead of the bar (``LEAD``), pulling the bar towards the robot.
* Phase B: lift the hand above the door, move to the panel's inner face near its free edge, lower the closed
  fingers beside it (palm above the panel top) and push the door further open along its arc until
  ``FINAL_ANGLE``. (Pulling on the bar alone cannot finish the job: at 80 degrees the bar's hook point would
  be out of the hand's workspace, y >= 0.348, for the nearer door positions.)

Everything is computed from the observation: the hinge follows from the goal (``goal = safe + (-0.3, -0.45, 0)``,
hinge = ``safe + (-0.185, -0.1, 0)``) and the door angle from the handle position around the hinge. Phases are
chosen with ``torch.where`` from the angle and from the hand's distance to the phase's waypoints.
"""

from __future__ import annotations

import math

import torch

from ..tasks._door import PUSH, PUSH_Z, door_point, hook_tcp
from ._common import action, move, parse

HINGE_FROM_GOAL = (0.115, 0.35)  # hinge (x, y) = goal + this
HANDLE_AT_ZERO = (0.325, -0.062)  # observed handle point relative to the hinge with the door closed
HANDLE_PHASE = math.atan2(HANDLE_AT_ZERO[1], HANDLE_AT_ZERO[0])
HANDLE_Z = 0.15  # handle height above the table
ABOVE_BAR_Z = 0.20  # TCP height while moving over the bar (fingertips clear its top at 0.173)
PUSH_INTO = 0.03  # phase B: normal offset of the pushing target (the fingers press into the panel's inner face)
CLEAR_Z = 0.31  # TCP height that clears the panel top (0.273) when moving between the phases
SWITCH_ANGLE = -0.6  # rad: phase A pulls the door this far, phase B pushes it on
LEAD = 0.3  # rad: the hand leads the door along its arc by this angle
FINAL_ANGLE = -1.7  # rad: push target (success needs -2 to -1.49)
RISE_FIRST = 0.04  # below high_z by more than this: rise straight up before travelling
ALIGNED = 0.015  # phase A: x-y tolerance before descending beside the bar
INNER_CLEAR = 0.045  # phase B: closed fingers (<= 2.7 cm from the TCP along the normal) clear of the panel
DESCEND_NEAR = 0.05  # phase B: x-y distance to the push point under which the hand may go down
ENGAGED = 0.08  # x-y distance to the current contact point under which a lowered hand counts as engaged


def door_angle(handle: torch.Tensor, goal: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Hinge position ``[..., 2]`` and door angle ``[...]`` (0 closed, negative open) from handle and goal."""
    hinge = torch.stack([goal[..., 0] + HINGE_FROM_GOAL[0], goal[..., 1] + HINGE_FROM_GOAL[1]], dim=-1)
    rel = handle[..., :2] - hinge
    return hinge, torch.atan2(rel[..., 1], rel[..., 0]) - HANDLE_PHASE


def _with_z(xy: torch.Tensor, z: torch.Tensor | float) -> torch.Tensor:
    z_t = torch.full_like(xy[..., 0], z) if isinstance(z, float) else z.expand(xy.shape[:-1])
    return torch.cat([xy, z_t[..., None]], dim=-1)


def _approach(hand: torch.Tensor, xy: torch.Tensor, low_z: torch.Tensor | float, high_z: float,
              clear: torch.Tensor, engaged: torch.Tensor, work: torch.Tensor) -> torch.Tensor:
    """Waypoint logic: ``work`` when engaged; else go down onto ``xy`` at ``low_z`` where ``clear``; else travel to
    ``xy`` at ``high_z`` (rising straight up first while more than ``RISE_FIRST`` below it)."""
    descend = _with_z(xy, low_z)
    above = _with_z(xy, high_z)
    rise = _with_z(hand[..., :2], high_z)
    low = hand[..., 2] < high_z - RISE_FIRST
    travel = torch.where(low[..., None], rise, above)
    target = torch.where(clear[..., None], descend, travel)
    return torch.where(engaged[..., None], work, target)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, handle, goal = o["tcp"], o["obj_pos"], o["goal"]
    hinge, theta = door_angle(handle, goal)
    handle_z = handle[..., 2]

    # phase A: pull the bar with the far finger
    hook_now = hook_tcp(hinge, theta)
    hook_lead = hook_tcp(hinge, theta - LEAD)
    near_a = (hand[..., :2] - hook_now).norm(dim=-1)
    engaged_a = (near_a <= ENGAGED) & (hand[..., 2] <= handle_z + 0.03)
    target_a = _approach(hand, hook_now, handle_z, ABOVE_BAR_Z, near_a <= ALIGNED, engaged_a,
                         _with_z(hook_lead, handle_z))

    # phase B: push the panel's inner face; the hand may go down as soon as the closed fingers are clear of the
    # panel's inner face (its distance from the panel plane, along the panel normal, exceeds INNER_CLEAR)
    push_now = door_point(hinge, theta, PUSH)
    push_lead = door_point(hinge, torch.clamp(theta - LEAD, min=FINAL_ANGLE), (PUSH[0], PUSH_INTO))
    rel = hand[..., :2] - hinge
    normal_offset = -rel[..., 0] * torch.sin(theta) + rel[..., 1] * torch.cos(theta)
    near_b = (hand[..., :2] - push_now).norm(dim=-1)
    clear_b = (normal_offset >= INNER_CLEAR) & (near_b <= DESCEND_NEAR)
    engaged_b = (near_b <= ENGAGED) & (hand[..., 2] <= PUSH_Z + 0.02)
    target_b = _approach(hand, push_now, PUSH_Z, CLEAR_Z, clear_b, engaged_b, _with_z(push_lead, PUSH_Z))

    phase_b = theta < SWITCH_ANGLE
    target = torch.where(phase_b[..., None], target_b, target_a)
    # fingers open while near the bar; closed in phase B once they are above it
    grip = torch.where(phase_b & (hand[..., 2] > HANDLE_Z + 0.06), 1.0, -1.0)
    return action(move(hand, target), grip)
