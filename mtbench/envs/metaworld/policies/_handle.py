"""Control helpers shared by the scripted handle policies (handle_press, handle_press_side, handle_pull,
handle_pull_side)."""

from __future__ import annotations

import torch

from ._common import action, move
from ._grasp import move_lead

HOVER = 0.06  # TCP height above the pressing point while aligning in x-y
ALIGNED = 0.01  # x-y distance under which the hand goes down
FINGERTIP_BELOW_TCP = 0.0094  # closed fingertips reach this far below the TCP
PRESS_BEYOND = 0.01  # TCP target this far below the point that puts the grip at the goal (the slide limit stops it)
PRESS_SPEED = 0.6


def press_down(hand: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """Closed fingers above the grip's top (``handle``), then straight down until the grip top is at the goal
    height (the target lies ``PRESS_BEYOND`` lower; the slide's end stops the handle)."""
    aligned = (hand[..., :2] - handle[..., :2]).norm(dim=-1) <= ALIGNED
    press_z = goal[..., 2] + FINGERTIP_BELOW_TCP - PRESS_BEYOND
    z = torch.where(aligned, press_z, torch.maximum(handle[..., 2] + HOVER, hand[..., 2]))
    target = torch.cat([handle[..., :2], z[..., None]], dim=-1)
    delta = move(hand, target)
    dz = torch.where(aligned, delta[..., 2].clamp(-PRESS_SPEED, PRESS_SPEED), delta[..., 2])
    return action(torch.cat([delta[..., :2], dz[..., None]], dim=-1), 1.0)


GRASP_ABOVE = 0.08  # approach height above the grasp point
GRASP_TOL = 0.006  # hand within this of the grasp point: close the fingers
PULL_BEYOND = 0.02  # pull target this far above the point that puts the grip at the goal


def pull_up(hand: torch.Tensor, prev_hand: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor,
            opened: torch.Tensor, grasp_offset: tuple[float, float, float], held_below: float) -> torch.Tensor:
    """Open fingers down onto the grasp point (``handle + grasp_offset``), close, and pull straight up until the
    grip is at the goal height. Stateless: "held" = hand at the grasp point with the fingers closed on something
    (openness between 0.2 and ``held_below``)."""
    dx, dy, dz = grasp_offset
    grasp = torch.stack([handle[..., 0] + dx, handle[..., 1] + dy, handle[..., 2] + dz], dim=-1)
    dist = (hand - grasp).norm(dim=-1)
    aligned = (hand[..., :2] - grasp[..., :2]).norm(dim=-1) <= ALIGNED
    held = (dist < 0.02) & (opened < held_below) & (opened > 0.2)
    close = (dist < GRASP_TOL) | held
    above = torch.cat([grasp[..., :2], torch.maximum(grasp[..., 2:] + GRASP_ABOVE, hand[..., 2:])], dim=-1)
    target = torch.where(aligned[..., None], grasp, above)
    lift = torch.cat([grasp[..., :2], (goal[..., 2] + dz + PULL_BEYOND)[..., None]], dim=-1)
    target = torch.where(held[..., None], lift, target)
    # lead the weld's lag so that the hand stops on the grasp point instead of overshooting it
    return action(move_lead(hand, prev_hand, target), torch.where(close, 1.0, -1.0))
