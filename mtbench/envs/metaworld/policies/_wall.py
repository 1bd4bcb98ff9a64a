"""Geometry of Meta-World's wall shared by the wall policies (reach_wall, push_wall, pick_place_wall)."""

from __future__ import annotations

import torch

WALL_LEFT_X = -0.02  # the wall spans x in [-0.02, 0.22]
WALL_FRONT_Y, WALL_BACK_Y = 0.74, 0.76
WALL_TOP_Z = 0.12
HAND_HALF_LENGTH = 0.102  # the hand box reaches this far either side of the TCP along y
HAND_HALF_WIDTH = 0.025  # ... and this far along x
HAND_ABOVE_TCP = 0.037  # the hand box's underside above the TCP
MARGIN = 0.006
# with the hand low and overlapping the wall in x, the TCP must stay in front of IN_FRONT_Y or behind BEHIND_Y
IN_FRONT_Y = WALL_FRONT_Y - HAND_HALF_LENGTH - 0.003  # 0.635
BEHIND_Y = WALL_BACK_Y + HAND_HALF_LENGTH + MARGIN  # 0.868
LOW_Z = WALL_TOP_Z - HAND_ABOVE_TCP + MARGIN  # TCP heights below this put the hand at the wall's height
BESIDE_X = WALL_LEFT_X - HAND_HALF_WIDTH - 0.01  # TCP x left of this keeps the hand beside the wall
# the table's retaining wall (front face y = 0.98, 12 cm tall): a low TCP stays in front of this
BEFORE_RETAINING_Y = 0.98 - HAND_HALF_LENGTH - 0.007  # 0.871


def clear_of_wall(p: torch.Tensor) -> torch.Tensor:
    """TCP target ``p`` ``[N, 3]`` moved back (+y) to ``BEHIND_Y`` where it is low, overlaps the wall in x and is
    too close behind it, and forward to ``BEFORE_RETAINING_Y`` where it is low and too close to the table's
    retaining wall (moves of at most 3 cm for the wall tasks' goals)."""
    low = p[:, 2] < LOW_Z
    y = torch.where(low & (p[:, 0] > BESIDE_X), p[:, 1].clamp_min(BEHIND_Y), p[:, 1])
    y = torch.where(p[:, 2] < LOW_Z + 0.02, y.clamp_max(BEFORE_RETAINING_Y), y)  # 2 cm more: overshoot
    return torch.stack([p[:, 0], y, p[:, 2]], dim=-1)
# |action| per axis while carrying the 0.75 kg puck: 1.5x push's carry speed (the puck is grasped at its centre and
# held in the air, where nothing drags it out of the grip)
CARRY_SPEED = 0.75
