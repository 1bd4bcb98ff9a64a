"""Drawer close: push an open drawer shut (Meta-World ``drawer-close-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import hamacher_product, tolerance
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._drawer import RESET_HIGH, RESET_LOW, SCENE, DrawerSceneMixin

MAX_DIST = 0.15  # Meta-World v3 starts the drawer pulled out by 15 cm
HANDLE_OFFSET = (0.0, -0.16, 0.05)  # observed handle point relative to drawer_link (Meta-World)
# MTBench's target: the handle pushed back through the travel = the closed handle point = cabinet + (0, -0.17, 0.14)
GOAL_OFFSET = (0.0, -0.17, 0.14)
TARGET_RADIUS = 0.025  # MTBench ("changed from .025")
HANDLE_REACH_RADIUS = 0.005
SUCCESS_RADIUS = 0.055


def drawer_close_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, handle_init: torch.Tensor,
                        init_tcp: torch.Tensor, grip_action: torch.Tensor
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """MTBench's dense term (before its ``* 0.01``): ``(H(H(reach, closed), in_place), reach, in_place)``.

    ``in_place = tol(‖handle − goal‖, (0, .025), margin |‖handle_init − goal‖ − .025|, long_tail)``, ``reach =
    tol(‖handle − tcp‖, (0, .005), margin |‖handle_init − init_tcp‖ − .005|, gaussian)``, ``closed =
    clip(a₃, 0, 1)``, H the Hamacher product.
    """
    target_to_obj = (handle - goal).norm(dim=-1)
    target_to_obj_init = (handle_init - goal).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS),
                         margin=(target_to_obj_init - TARGET_RADIUS).abs(), sigmoid="long_tail")
    tcp_to_obj = (handle - tcp).norm(dim=-1)
    tcp_to_obj_init = (handle_init - init_tcp).norm(dim=-1)
    reach = tolerance(tcp_to_obj, bounds=(0.0, HANDLE_REACH_RADIUS),
                      margin=(tcp_to_obj_init - HANDLE_REACH_RADIUS).abs(), sigmoid="gaussian")
    reach = hamacher_product(reach, grip_action.clamp(0.0, 1.0))
    return hamacher_product(reach, in_place), reach, in_place


def drawer_close_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − goal‖ ≤ 0.055`` (the goal is the closed handle point)."""
    return (handle - goal).norm(dim=-1) <= SUCCESS_RADIUS


class DrawerClose(DrawerSceneMixin, MetaWorldTask):
    """Push the drawer closed (Meta-World ``drawer-close-v3`` on the Panda).

    * Reset: the cabinet is placed at x ~ U[-0.1, 0.1], y = 0.9 (Meta-World frame) with the drawer pulled out by
      15 cm (slide at -0.15, Meta-World v3's ``-maxDist``; MTBench starts at its 16 cm travel limit). Goal
      (MTBench's ``target_pos``) = the closed handle point = cabinet + (0, -0.17, 0.14).
    * Observation: object 1 = the handle point ``drawer_link + (0, -0.16, 0.05)`` (5 cm above and 1 cm in front
      of the bar's axis), zero quaternion (as Meta-World); no object 2. ``obj_init_pos`` is that point at reset.
    * Dense reward (paper-era MTBench ``task_fns/drawer_close.py``): ``H(H(reach, clip(a₃, 0, 1)), in_place)``
      (see :func:`drawer_close_reward`), ``dense_scale`` 0.01.
    * Success: ``‖handle − goal‖ ≤ 0.055``: the drawer is open by at most 5.5 cm.
    * Differences to Meta-World v2: its goal is the closed bar's axis (5 cm below the observed point), its
      in-place radius 0.05 and its reward 10 times larger; the hand starts with the TCP at (0, 0.6, 0.2) (Meta-World's
      ``hand_init_pos``).
    """

    name = "drawer_close"
    mtbench_id = 17
    description = "Push an open drawer back into its cabinet."
    scene = SCENE
    reset_low = RESET_LOW
    reset_high = RESET_HIGH

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        cabinet = vec[:, :3]
        self.place_drawer(s, cabinet, -MAX_DIST, mask)
        self.masked_set(s.goal, offset(cabinet, *GOAL_OFFSET), mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        # Meta-World: obj_init_pos = the handle point after the drawer was pulled out
        self.masked_set(s.obj_init_pos, s.obj_pos, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(self.handle_point(s, HANDLE_OFFSET))

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return drawer_close_reward(s.tcp, s.obj_pos, s.goal, s.obj_init_pos, s.init_tcp, action[:, 3])[0]

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return drawer_close_success(s.obj_pos, s.goal)
