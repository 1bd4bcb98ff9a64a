"""Drawer open: pull a drawer out of its cabinet by the handle (Meta-World ``drawer-open-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._drawer import RESET_HIGH, RESET_LOW, SCENE, SLIDE_TRAVEL, DrawerSceneMixin

HANDLE_OFFSET = (0.0, -0.16, 0.0)  # observed handle point relative to drawer_link (Meta-World)
# MTBench's target: the handle pulled out through the full 16 cm travel. With the slide closed the handle point is
# the cabinet + (0, -0.17, 0.09), so the target is the cabinet + (0, -0.33, 0.09)
GOAL_OFFSET = (0.0, -0.17 - SLIDE_TRAVEL, 0.09)
INIT_FROM_GOAL = 0.2  # MTBench's handle_pos_init = target + 0.2 along the pull axis (Meta-World's maxDist)
SUCCESS_RADIUS = 0.035


def drawer_open_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor,
                       init_tcp: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """MTBench's dense term (before its ``* 0.05``): ``(caging + opening, caging, opening)``, each ``[n]``.

    ``opening = tol(‖handle − goal‖, (0, .02), margin .2, long_tail)``; ``caging = tol(‖handle − tcp‖, (0, .01),
    margin ‖handle_init − init_tcp‖, long_tail)`` with ``handle_init = goal + 0.2`` along the pull axis (+y here).
    """
    opening = tolerance((handle - goal).norm(dim=-1), bounds=(0.0, 0.02), margin=0.2, sigmoid="long_tail")
    handle_init = offset(goal, 0.0, INIT_FROM_GOAL, 0.0)
    caging = tolerance((handle - tcp).norm(dim=-1), bounds=(0.0, 0.01),
                       margin=(handle_init - init_tcp).norm(dim=-1), sigmoid="long_tail")
    return caging + opening, caging, opening


def drawer_open_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − goal‖ ≤ 0.035`` (the goal is the fully open handle point)."""
    return (handle - goal).norm(dim=-1) <= SUCCESS_RADIUS


class DrawerOpen(DrawerSceneMixin, MetaWorldTask):
    """Pull the drawer open (Meta-World ``drawer-open-v3`` on the Panda).

    * Reset: the cabinet is placed at x ~ U[-0.1, 0.1], y = 0.9 (MTBench: root x_mtb = .3, y_mtb ~ U[-.1, .1];
      Meta-World's ``obj_low/obj_high``), drawer closed. Goal (MTBench's ``target_pos``) = the handle point pulled
      out through the full 16 cm travel = cabinet + (0, -0.33, 0.09).
    * Observation: object 1 = the handle point ``drawer_link + (0, -0.16, 0)`` (1 cm in front of the bar's axis)
      with ``drawer_link``'s orientation; no object 2.
    * Dense reward (paper-era MTBench ``task_fns/drawer_open.py``): ``caging + opening`` (see
      :func:`drawer_open_reward`; MTBench's caging ``scale`` is (1, 1, 1)) times ``dense_scale`` 0.05 (MTBench's
      drawer_open exception to 0.01).
    * Success: ``‖handle − goal‖ ≤ 0.035``, i.e. the drawer is pulled out by at least 12.5 cm.
    * Differences to Meta-World v2: its goal lies 4 cm beyond the slide limit and its caging error is scaled by
      (3, 3, 1); its success needs ``‖handle − goal‖ ≤ 0.03``. The Panda starts with its TCP at Meta-World's
      ``hand_init_pos`` (0, 0.6, 0.2).
    * Physics note: the Panda hand (10.4 cm either side of the TCP along the finger axis, its underside 3.7 cm
      above the TCP) cannot get a finger fully behind the handle bar (the drawer's front wall, 5 cm behind the
      bar, stops the hand; the Sawyer's long fingers reach past it). The drawer still opens by hooking a fingertip
      over the back of the round bar from above (see the scripted policy).
    """

    name = "drawer_open"
    mtbench_id = 18
    description = "Grab the drawer handle and pull the drawer open."
    scene = SCENE
    reset_low = RESET_LOW
    reset_high = RESET_HIGH
    dense_scale = 0.05

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        cabinet = vec[:, :3]
        self.place_drawer(s, cabinet, 0.0, mask)
        self.masked_set(s.goal, offset(cabinet, *GOAL_OFFSET), mask)
        self.masked_set(s.obj_init_pos, cabinet, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(self.handle_point(s, HANDLE_OFFSET), s.sim.xquat[:, self.drawer_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return drawer_open_reward(s.tcp, s.obj_pos, s.goal, s.init_tcp)[0]

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return drawer_open_success(s.obj_pos, s.goal)
