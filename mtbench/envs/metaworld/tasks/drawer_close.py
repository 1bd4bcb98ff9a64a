"""Drawer close: push an open drawer shut (Meta-World ``drawer-close-v3``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState, pad_object_state
from ._drawer import (
    CLOSE_GOAL_OFFSET,
    CLOSE_HANDLE_OFFSET,
    CLOSE_MAX_DIST,
    RESET_HIGH,
    RESET_LOW,
    SCENE,
    DrawerSceneMixin,
    shift,
    drawer_close_reward,
    drawer_close_success,
)


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
    scene = SCENE
    reset_low = RESET_LOW
    reset_high = RESET_HIGH

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        cabinet = vec[:, :3]
        self.place_drawer(s, cabinet, -CLOSE_MAX_DIST, mask)
        goal = shift(cabinet, CLOSE_GOAL_OFFSET)
        s.goal.copy_(torch.where(mask[:, None], goal, s.goal))

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        # Meta-World: obj_init_pos = the handle point after the drawer was pulled out
        s.obj_init_pos.copy_(torch.where(mask[:, None], self.handle_pos(s), s.obj_init_pos))

    def handle_pos(self, s: TaskState) -> torch.Tensor:
        return shift(self.drawer_link_pos(s), CLOSE_HANDLE_OFFSET)

    def object_state(self, s: TaskState) -> torch.Tensor:
        pose = torch.cat([self.handle_pos(s), s.tcp.new_zeros(s.n, 4)], dim=-1)
        return pad_object_state(pose)

    def evaluate(self, s, action, obs):
        handle = self.handle_pos(s)
        dense, _, _ = drawer_close_reward(s.tcp, handle, s.goal, s.obj_init_pos, s.init_tcp, action[:, 3])
        return dense, drawer_close_success(handle, s.goal)
