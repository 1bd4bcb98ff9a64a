"""Pieces shared by the wall tasks (reach_wall, push_wall, pick_place_wall; Meta-World ``sawyer_*_wall_v3.xml``).

The scene: Meta-World's brick wall, a world-fixed box centred at (0.1, 0.75, 0.06) with half sizes
(0.12, 0.01, 0.06): it spans x in [-0.02, 0.22], y in [0.74, 0.76] and rises 12 cm above the table. The object
starts in front of it (y 0.6 .. 0.65), the goal lies behind it (y 0.85 .. 0.9).

MTBench's wall (its own ``push_wall.xml`` asset: the same box, turned to lie across the table at x_mtb = 0.15)
is centred on x = 0 of our frame and sunk 3 cm into its table (9 cm above it); we keep Meta-World's wall, as the
MT10 tasks keep Meta-World's fixtures.

MTBench's push_wall and pick_place_wall rewards (``task_fns/push_wall.py``, ``pick_place_wall.py``) scale distances
by ``in_place_scaling = (3, 1, 1)`` in MTBench's frame, whose x axis is our y axis (``x_mtb = y - 0.6``): the
scaling is ``(1, 3, 1)`` here (:func:`scaled_norm`; the forward distance counts three times; Meta-World's own
``(3, 1, 1)`` scales the lateral axis). Each task file composes its own reward; the ``V2_*`` constants and
:func:`wall_stage` are the pieces their ``reward_version="v2"`` paths share.
"""

from __future__ import annotations

import torch

WALL_XML_CENTRE = (0.1, 0.75, 0.06)
WALL_HALF_SIZE = (0.12, 0.01, 0.06)
IN_PLACE_SCALING = (1.0, 3.0, 1.0)  # MTBench (3, 1, 1) in its frame
MIDPOINT_Y = 0.77  # MTBench's midpoints: x_mtb = 0.17, just behind the wall's back face (y = 0.76)


def scaled_norm(v: torch.Tensor) -> torch.Tensor:
    """``‖v · IN_PLACE_SCALING‖`` for vectors ``[..., 3]`` (no host-to-device copy)."""
    sx, sy, sz = IN_PLACE_SCALING
    return torch.stack([v[..., 0] * sx, v[..., 1] * sy, v[..., 2] * sz], dim=-1).norm(dim=-1)

# reward_version="v2" (push_wall, pick_place_wall): the hand reaches 10.2 cm either side of the TCP along y
V2_HOLD_RADIUS = 0.025  # TCP within 2.5 cm of the puck's centre
V2_LIFT_Y = 0.625  # the puck leaves its start sideways or upwards at most here (the hand still before the wall)
V2_BEHIND_Y = 0.87  # the puck crosses to here (the hand clear of the wall's back face) before going to the goal
V2_PAST_WALL_Y = 0.78  # puck past the wall's back face (0.76) by its radius: the way to the goal is free


def wall_stage(obj: torch.Tensor, moved_on: torch.Tensor) -> torch.Tensor:
    """v2 waypoint index ``[n]`` of the puck's way past the wall: 0 before the wall, 1 before the wall where
    ``moved_on`` (the puck lifted above the wall, or in the lane beside its end), 2 once it is past the wall (by
    any route)."""
    return torch.where(obj[:, 1] >= V2_PAST_WALL_Y, 2, moved_on.long())
