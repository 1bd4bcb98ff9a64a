"""Plate-slide: slide a plate forward into a goal cabinet (Meta-World ``plate-slide-v3``, MTBench
``task_fns/plate_slide.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import hamacher_product
from ..task import MetaWorldTask, TaskState, offset
from ._plate import PLATE_Z, SCENE, TARGET_RADIUS, PlateSceneMixin, plate_in_place, plate_near

TARGET_FROM_GOAL = (0.0, -0.025, 0.0)  # MTBench: (-0.025, 0, 0) in its frame, "added an offset to make it easier"
CABINET_FROM_GOAL = (0.0, 0.0, -0.015)


def plate_slide_reward(obj: torch.Tensor, tcp: torch.Tensor, target: torch.Tensor, obj_init_pos: torch.Tensor,
                       init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench: ``8 · hamacher(near(‖tcp − plate‖), in_place(‖plate − target‖))`` ``[n]`` (see ``_plate``)."""
    return 8.0 * hamacher_product(plate_near(tcp, obj, init_tcp, obj_init_pos),
                                  plate_in_place(obj, target, obj_init_pos))


def plate_slide_success(obj: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """``‖plate − target‖ < 0.05``."""
    return (obj - target).norm(dim=-1) < TARGET_RADIUS


class PlateSlide(PlateSceneMixin, MetaWorldTask):
    """Slide the plate (see ``_plate``) forward (+y) into the cabinet.

    * Reset (MTBench mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): the plate at (0, 0.6,
      0.015) (Meta-World's start); a point ``g`` with x ~ U[-0.1, 0.1], y ~ U[0.85, 0.9], z = 0 (Meta-World's goal
      range); the cabinet at ``g + (0, 0, -0.015)`` (Meta-World: at ``g``); the goal (the observed and rewarded
      target) at ``g + (0, -0.025, 0)``, 2.5 cm in front of the cabinet centre (MTBench's "offset to make it
      easier"; Meta-World's target is ``g``).
    * Objects: the plate's centre and orientation.
    * Dense reward (MTBench, before its ``× 0.01``): ``8 · hamacher(near, in_place)`` with ``near =
      tolerance(‖tcp − plate‖, (0, .05), margin=max(‖init_tcp − plate_init‖ − .05, 0), long_tail)`` and
      ``in_place = tolerance(‖plate − goal‖, (0, .05), margin=max(‖plate_init − goal‖ − .05, 0), long_tail)``
      (Meta-World: the margins without ``− .05``).
    * Success: ``‖plate − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``), in 3-D: the goal lies at the table
      height, 1.5 cm below the plate's centre, so the plate must come within 4.77 cm of it in x-y.
    """

    name = "plate_slide"
    mtbench_id = 36
    description = "Slide a plate forward into a cabinet."
    scene = SCENE
    # plate x, y, z (MTBench's sampled object point; the plate centre is 1.5 cm higher) then g x, y, z
    reset_low = (0.0, 0.6, 0.0, -0.1, 0.85, 0.0)
    reset_high = (0.0, 0.6, 0.0, 0.1, 0.9, 0.0)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        g = vec[:, 3:6]
        self.place_plate(s, offset(vec[:, :3], 0.0, 0.0, PLATE_Z), offset(g, *CABINET_FROM_GOAL),
                         offset(g, *TARGET_FROM_GOAL), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_reward(s.obj_pos, s.tcp, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return plate_slide_success(s.obj_pos, s.goal)
