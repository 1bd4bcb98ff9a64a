"""Drawer close: push an open drawer shut (Meta-World ``drawer-close-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import hamacher_product, tolerance
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._drawer import RESET_HIGH, RESET_LOW, SCENE, DrawerSceneMixin

MAX_DIST = 0.15  # Meta-World v3 starts the drawer pulled out by 15 cm
HANDLE_OFFSET = (0.0, -0.16, 0.05)  # observed handle point relative to drawer_link (Meta-World)
GOAL_OFFSET = (0.0, -0.16, 0.09)  # goal relative to the cabinet (Meta-World)
# Meta-World's compute_reward reads self.TARGET_RADIUS, i.e. SawyerXYZEnv's 0.05; the class attribute
# _TARGET_RADIUS = 0.04 of SawyerDrawerCloseEnvV3 is never used
TARGET_RADIUS = 0.05
HANDLE_REACH_RADIUS = 0.005
# MTBench success target: the closed handle point = cabinet + (0, -0.17, 0.14) = goal + (0, -0.01, 0.05)
SUCCESS_FROM_GOAL = (0.0, -0.01, 0.05)
SUCCESS_RADIUS = 0.055


def drawer_close_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, handle_init: torch.Tensor,
                        init_tcp: torch.Tensor, grip_action: torch.Tensor
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Meta-World v2 ``SawyerDrawerCloseEnvV3.compute_reward`` without its success override (``reward = 1``
    when ``‖handle − target‖ ≤ 0.065``). Returns ``(10 · H(H(reach, closed), in_place), reach, in_place)``."""
    target_to_obj = (handle - goal).norm(dim=-1)
    target_to_obj_init = (handle_init - goal).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS),
                         margin=(target_to_obj_init - TARGET_RADIUS).abs(), sigmoid="long_tail")
    tcp_to_obj = (handle - tcp).norm(dim=-1)
    tcp_to_obj_init = (handle_init - init_tcp).norm(dim=-1)
    reach = tolerance(tcp_to_obj, bounds=(0.0, HANDLE_REACH_RADIUS),
                      margin=(tcp_to_obj_init - HANDLE_REACH_RADIUS).abs(), sigmoid="gaussian")
    gripper_closed = grip_action.clamp(0.0, 1.0)
    reach = hamacher_product(reach, gripper_closed)
    return 10.0 * hamacher_product(reach, in_place), reach, in_place


def drawer_close_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − closed handle‖ ≤ 0.055`` (see :class:`..drawer_close.DrawerClose`)."""
    target = offset(goal, *SUCCESS_FROM_GOAL)
    return (handle - target).norm(dim=-1) <= SUCCESS_RADIUS


class DrawerClose(DrawerSceneMixin, MetaWorldTask):
    """Push the drawer closed (Meta-World ``drawer-close-v3`` on the Panda).

    * Reset: the cabinet is placed at x ~ U[-0.1, 0.1], y = 0.9 (Meta-World frame) with the drawer pulled out by
      15 cm (slide at -0.15, Meta-World v3's ``-maxDist``). Goal (Meta-World's ``_target_pos``) = cabinet +
      (0, -0.16, 0.09).
    * Observation: object 1 = the handle point ``drawer_link + (0, -0.16, 0.05)`` (5 cm above and 1 cm in front
      of the bar's axis), zero quaternion (as Meta-World); no object 2. ``obj_init_pos`` is that point at reset.
    * Dense reward: Meta-World v2 ``10 · H(H(reach, clip(a₃, 0, 1)), in_place)`` with ``in_place =
      tol(‖handle − goal‖, (0, .05), margin |‖handle_init − goal‖ − .05|, long_tail)`` and ``reach =
      tol(‖handle − tcp‖, (0, .005), margin |‖handle_init − tcp_init‖ − .005|, gaussian)`` (H = Hamacher
      product), without Meta-World's success override (reward 10 when ``‖handle − goal‖ ≤ .065``: the env pays
      the success bonus instead). The radius is 0.05: Meta-World's ``compute_reward`` reads the base class's
      ``TARGET_RADIUS``, not the drawer-close class's unused ``_TARGET_RADIUS = 0.04``. ``dense_scale`` 0.01.
    * Success (paper-era MTBench): ``‖handle − target‖ ≤ 0.055`` where MTBench's target is the initial handle
      position + 0.16 along the push direction, i.e. the closed handle. In Meta-World's frame that is the
      observed handle point with the slide at 0: ``cabinet + (0, -0.17, 0.14) = goal + (0, -0.01, 0.05)``; success
      means the drawer is open by at most 5.5 cm. (Meta-World's own rule ``‖handle − goal‖ ≤ 0.05 + 0.015``
      compares points 5 cm apart in height and needs the drawer within 3.2 cm of closed.)
    * Differences: the hand starts at the TCP position (0, 0.6, 0.2) (Meta-World's ``hand_init_pos``).
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
