"""Plate-slide-back-side: slide a plate sideways, away from the goal cabinet (Meta-World
``plate-slide-back-side-v3``, MTBench ``task_fns/plate_slide_back_side.py``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState, offset
from ._plate import (NEAR_RADIUS, NEAR_Z, PLATE_Z, SIDEWAY_SCENE, TARGET_RADIUS, PlateSceneMixin, plate_in_place,
                     plate_near)

PLATE_FROM_CABINET = (0.25, 0.0, 0.0)  # MTBench: obj_init = sampled point + (0, -0.25, 0) in its frame
# MTBench "moves the obj pos ... so the gripper pushes back from the FRONT of the puck": (0, 0.05, 0) in its frame,
# the plate's edge on the cabinet side
REACH_FROM_PLATE = (-0.05, 0.0, 0.0)


def plate_slide_back_side_reward(obj: torch.Tensor, tcp: torch.Tensor, target: torch.Tensor,
                                 obj_init_pos: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench ``[n]``: with ``p = plate + (-0.05, 0, 0)``: ``1.5 · near(‖tcp − p‖)``, or ``2 + 7 · in_place`` while the
    TCP is at most 5 cm above the table and within 7 cm of ``p`` (see ``_plate``)."""
    point = offset(obj, *REACH_FROM_PLATE)
    near = plate_near(tcp, point, init_tcp, obj_init_pos)
    at_plate = (tcp[:, 2] <= NEAR_Z) & ((tcp - point).norm(dim=-1) < NEAR_RADIUS)
    return torch.where(at_plate, 2.0 + 7.0 * plate_in_place(obj, target, obj_init_pos), 1.5 * near)


def plate_slide_back_side_success(obj: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """``‖plate − target‖ < 0.05``."""
    return (obj - target).norm(dim=-1) < TARGET_RADIUS


class PlateSlideBackSide(PlateSceneMixin, MetaWorldTask):
    """Slide the plate (see ``_plate``) sideways (+x), away from the cabinet whose opening faces +x.

    * Reset (MTBench mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): the cabinet at MTBench's
      sampled object point (-0.3, 0.6, 0) (the sideway XML's position; Meta-World moves it to (-0.25, 0.6, 0)); the
      plate at that point + (0.25, 0, 0.015) = (-0.05, 0.6, 0.015), 13 cm in front of the cabinet's posts
      (MTBench's ``obj_init_pos`` has z = 0, the table, where its free plate was pushed up to 0.015; Meta-World
      starts the plate at (-0.15, 0.6, 0.015), half inside the cabinet); goal x ~ U[0.05, 0.25], y = 0.6, z = 0.02
      (Meta-World: x in [-0.05, 0.15], z = 0.015).
    * Objects: the plate's centre and orientation.
    * Dense reward (MTBench, before its ``× 0.01``): with ``p = plate + (-0.05, 0, 0)`` (the edge on the cabinet
      side): ``r = 1.5 · near(p)``; if ``tcp_z <= 0.05`` and ``‖tcp − p‖ < 0.07``: ``r = 2 + 7 · in_place``
      (``near``/``in_place``: see ``_plate``; Meta-World measures from the plate centre, asks ``tcp_z <= 0.03`` and
      does not clamp the margins).
    * Success: ``‖plate − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``).
    """

    name = "plate_slide_back_side"
    mtbench_id = 33
    description = "Slide a plate sideways back out of the goal cabinet."
    scene = SIDEWAY_SCENE
    # cabinet x, y, z (MTBench's sampled object point) then goal x, y, z
    reset_low = (-0.3, 0.6, 0.0, 0.05, 0.6, 0.02)
    reset_high = (-0.3, 0.6, 0.0, 0.25, 0.6, 0.02)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        cabinet = vec[:, :3]
        plate = offset(cabinet, PLATE_FROM_CABINET[0], PLATE_FROM_CABINET[1], PLATE_FROM_CABINET[2] + PLATE_Z)
        self.place_plate(s, plate, cabinet, vec[:, 3:6], mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_back_side_reward(s.obj_pos, s.tcp, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_back_side_success(s.obj_pos, s.goal)
