"""Drawer open: pull a drawer out of its cabinet by the handle (Meta-World ``drawer-open-v3``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState, pad_object_state
from ._drawer import (
    OPEN_GOAL_OFFSET,
    OPEN_HANDLE_OFFSET,
    RESET_HIGH,
    RESET_LOW,
    SCENE,
    DrawerSceneMixin,
    shift,
    drawer_open_reward,
    drawer_open_success,
)


class DrawerOpen(DrawerSceneMixin, MetaWorldTask):
    """Pull the drawer open (Meta-World ``drawer-open-v3`` on the Panda).

    * Reset: the cabinet is placed at x ~ U[-0.1, 0.1], y = 0.9 (Meta-World's ``obj_low/obj_high``; Meta-World
      frame) with the drawer closed. Goal (Meta-World's ``_target_pos``) = cabinet + (0, -0.36, 0.09): 20 cm in
      front of the closed handle point, i.e. 4 cm beyond the 16 cm slide range.
    * Observation: object 1 = the handle point ``drawer_link + (0, -0.16, 0)`` (1 cm in front of the bar's axis)
      with ``drawer_link``'s orientation; no object 2.
    * Dense reward: Meta-World v2 ``caging + opening`` with ``opening = tol(‖handle − goal‖, (0, .02), margin
      .2, long_tail)`` and ``caging = tol(‖(handle − tcp)·(3, 3, 1)‖, (0, .01), margin ‖(handle_init −
      tcp_init)·(3, 3, 1)‖, long_tail)``. Meta-World multiplies this by 5, MTBench by 0.05 (its drawer_open
      exception to the usual 0.01). We return it without Meta-World's 5 and set ``dense_scale = 0.05``, so the
      env's non-success reward ``dense · 0.05 · reward_scale(100) = 5 · (caging + opening)`` equals Meta-World's
      dense reward (range [0, 10]) and MTBench's. Note that ``evaluate`` therefore returns Meta-World's dense
      reward divided by 5 (range [0, 2]).
    * Success (paper-era MTBench): ``‖handle − target‖ ≤ 0.035`` where MTBench's target is the closed handle
      position + 0.16 along the pull direction, i.e. the fully open handle. In Meta-World's frame that is
      ``cabinet + (0, -0.33, 0.09) = goal + (0, 0.03, 0)``; since the handle moves along y only, success means
      the drawer is pulled out by at least 12.5 cm. Meta-World's own rule (``‖handle − goal‖ ≤ 0.03``) needs the
      slide at its -0.16 limit (or beyond, through the soft limit).
    * Differences: Meta-World's caging term measures the handle against ``obs[:3]``, the Sawyer's hand body; ours
      is the TCP (our ``obs[:3]``; its initial value uses the TCP in both). The Panda starts with its TCP at
      Meta-World's ``hand_init_pos`` (0, 0.6, 0.2).
    * Physics note: the Panda hand (10.4 cm either side of the TCP along the finger axis, its underside 3.7 cm
      above the TCP) cannot get a finger fully behind the handle bar (the drawer's front wall, 5 cm behind the
      bar, stops the hand; the Sawyer's long fingers reach past it). The drawer still opens by hooking a fingertip
      over the back of the round bar from above (see the scripted policy).
    """

    name = "drawer_open"
    scene = SCENE
    reset_low = RESET_LOW
    reset_high = RESET_HIGH
    dense_scale = 0.05

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        cabinet = vec[:, :3]
        self.place_drawer(s, cabinet, 0.0, mask)
        goal = shift(cabinet, OPEN_GOAL_OFFSET)
        s.goal.copy_(torch.where(mask[:, None], goal, s.goal))
        s.obj_init_pos.copy_(torch.where(mask[:, None], cabinet, s.obj_init_pos))

    def handle_pos(self, s: TaskState) -> torch.Tensor:
        return shift(self.drawer_link_pos(s), OPEN_HANDLE_OFFSET)

    def object_state(self, s: TaskState) -> torch.Tensor:
        pose = torch.cat([self.handle_pos(s), s.sim.xquat[:, self.drawer_body]], dim=-1)
        return pad_object_state(pose)

    def evaluate(self, s, action, obs):
        handle = self.handle_pos(s)
        dense, _, _ = drawer_open_reward(s.tcp, handle, s.goal, s.init_tcp)
        return dense, drawer_open_success(handle, s.goal)
