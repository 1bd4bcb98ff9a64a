"""Plate-slide-back: slide a plate backwards, towards the robot, away from the goal cabinet (Meta-World
``plate-slide-back-v3``, MTBench ``task_fns/plate_slide_back.py``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState, offset
from ._plate import (NEAR_RADIUS, NEAR_Z, PLATE_Z, SCENE, TARGET_RADIUS, PlateSceneMixin, plate_in_place,
                     plate_near)

CABINET_FROM_GOAL = (0.0, 0.3, -0.015)  # MTBench: (0.3, 0, -0.015) in its frame
# MTBench "moves the obj pos forward a bit so the gripper pushes back from the FRONT of the puck": (0.05, 0, 0) in
# its frame, the plate's far edge
REACH_FROM_PLATE = (0.0, 0.05, 0.0)


def plate_slide_back_reward(obj: torch.Tensor, tcp: torch.Tensor, target: torch.Tensor, obj_init_pos: torch.Tensor,
                            init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench ``[n]``: with ``p = plate + (0, 0.05, 0)``: ``1.5 · near(‖tcp − p‖)``, or ``2 + 7 · in_place`` while the
    TCP is at most 5 cm above the table and within 7 cm of ``p`` (see ``_plate``)."""
    point = offset(obj, *REACH_FROM_PLATE)
    near = plate_near(tcp, point, init_tcp, obj_init_pos)
    at_plate = (tcp[:, 2] <= NEAR_Z) & ((tcp - point).norm(dim=-1) < NEAR_RADIUS)
    return torch.where(at_plate, 2.0 + 7.0 * plate_in_place(obj, target, obj_init_pos), 1.5 * near)


def plate_slide_back_success(obj: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """``‖plate − target‖ < 0.05``."""
    return (obj - target).norm(dim=-1) < TARGET_RADIUS


class PlateSlideBack(PlateSceneMixin, MetaWorldTask):
    """Slide the plate (see ``_plate``) back (-y) from in front of the cabinet to the goal near the robot.

    * Reset (MTBench mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): the plate at (0, 0.75,
      0.015) (Meta-World's start, slide 0.15); goal x ~ U[-0.1, 0.1], y = 0.6, z = 0.02 (Meta-World: z = 0.015);
      the cabinet at ``goal + (0, 0.3, -0.015)`` = (goal x, 0.9, 0.005), its posts 3 cm behind the plate's far
      edge (Meta-World keeps it at (0, 0.85, 0), where the plate starts half inside it).
    * Objects: the plate's centre and orientation.
    * Dense reward (MTBench, before its ``× 0.01``): with ``p = plate + (0, 0.05, 0)`` (the far edge): ``r = 1.5 ·
      near(p)``; if ``tcp_z <= 0.05`` and ``‖tcp − p‖ < 0.07``: ``r = 2 + 7 · in_place`` (``near``/``in_place``: see
      ``_plate``; Meta-World measures from the plate centre, asks ``tcp_z <= 0.03`` and does not clamp the
      margins).
    * Success: ``‖plate − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``).
    """

    name = "plate_slide_back"
    mtbench_id = 34
    description = "Slide a plate backward out of the goal cabinet towards the robot."
    scene = SCENE
    # plate x, y, z (MTBench's sampled object point; the plate centre is 1.5 cm higher) then goal x, y, z
    reset_low = (0.0, 0.75, 0.0, -0.1, 0.6, 0.02)
    reset_high = (0.0, 0.75, 0.0, 0.1, 0.6, 0.02)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        goal = vec[:, 3:6]
        self.place_plate(s, offset(vec[:, :3], 0.0, 0.0, PLATE_Z), offset(goal, *CABINET_FROM_GOAL), goal, mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_back_reward(s.obj_pos, s.tcp, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_back_success(s.obj_pos, s.goal)
