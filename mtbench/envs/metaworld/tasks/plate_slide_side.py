"""Plate-slide-side: slide a plate sideways into a goal cabinet (Meta-World ``plate-slide-side-v3``, MTBench
``task_fns/plate_slide_side.py``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState, offset
from ._plate import (NEAR_RADIUS, NEAR_Z, PLATE_Z, SIDEWAY_SCENE, TARGET_RADIUS, PlateSceneMixin, plate_in_place,
                     plate_near)

TARGET_FROM_GOAL = (0.025, 0.0, 0.015)  # MTBench: (0, -0.025, 0.015) in its frame, "an offset to make it easier"
CABINET_FROM_GOAL = (0.0, 0.0, -0.015)


def plate_slide_side_reward(obj: torch.Tensor, tcp: torch.Tensor, target: torch.Tensor, obj_init_pos: torch.Tensor,
                            init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench ``[n]``: ``1.5 · near(‖tcp − plate‖)``, or ``2 + 7 · in_place`` while the TCP is at most 5 cm above
    the table and within 7 cm of the plate (see ``_plate``)."""
    near = plate_near(tcp, obj, init_tcp, obj_init_pos)
    at_plate = (tcp[:, 2] <= NEAR_Z) & ((tcp - obj).norm(dim=-1) < NEAR_RADIUS)
    return torch.where(at_plate, 2.0 + 7.0 * plate_in_place(obj, target, obj_init_pos), 1.5 * near)


def plate_slide_side_success(obj: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """``‖plate − target‖ < 0.05``."""
    return (obj - target).norm(dim=-1) < TARGET_RADIUS


class PlateSlideSide(PlateSceneMixin, MetaWorldTask):
    """Slide the plate (see ``_plate``) sideways (-x) into the cabinet, whose opening faces +x.

    * Reset (MTBench mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): the plate at (0, 0.6,
      0.015) (Meta-World's start); a point ``g`` with x ~ U[-0.3, -0.25], y ~ U[0.54, 0.66], z = 0 (Meta-World's
      goal range); the cabinet at ``g + (0, 0, -0.015)`` (Meta-World leaves it at (-0.3, 0.6, 0)); the goal at
      ``g + (0.025, 0, 0.015)``, 2.5 cm in front of the cabinet centre at the plate's height (MTBench's "offset to
      make it easier"; Meta-World's target is ``g``).
    * Objects: the plate's centre and orientation.
    * Dense reward (MTBench, before its ``× 0.01``): ``r = 1.5 · near``; if ``tcp_z <= 0.05`` and ``‖tcp − plate‖ <
      0.07``: ``r = 2 + 7 · in_place`` (``near``/``in_place``: see ``_plate``; Meta-World asks ``tcp_z <= 0.03``
      and uses margins without ``− .05`` clamped at 0).
    * Success: ``‖plate − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``).
    """

    name = "plate_slide_side"
    mtbench_id = 35
    description = "Slide a plate sideways into a cabinet."
    scene = SIDEWAY_SCENE
    # plate x, y, z (MTBench's sampled object point; the plate centre is 1.5 cm higher) then g x, y, z
    reset_low = (0.0, 0.6, 0.0, -0.3, 0.54, 0.0)
    reset_high = (0.0, 0.6, 0.0, -0.25, 0.66, 0.0)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        g = vec[:, 3:6]
        self.place_plate(s, offset(vec[:, :3], 0.0, 0.0, PLATE_Z), offset(g, *CABINET_FROM_GOAL),
                         offset(g, *TARGET_FROM_GOAL), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_side_reward(s.obj_pos, s.tcp, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_side_success(s.obj_pos, s.goal)
