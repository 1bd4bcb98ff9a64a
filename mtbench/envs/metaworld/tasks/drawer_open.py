"""Drawer open: pull a drawer out of its cabinet by the handle (Meta-World ``drawer-open-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._drawer import RESET_HIGH, RESET_LOW, SCENE, SLIDE_TRAVEL, DrawerSceneMixin

MAX_DIST = 0.2  # Meta-World's maxDist: the goal is 20 cm in front of the closed handle
HANDLE_OFFSET = (0.0, -0.16, 0.0)  # observed handle point relative to drawer_link (Meta-World)
GOAL_OFFSET = (0.0, -0.16 - MAX_DIST, 0.09)  # goal relative to the cabinet (Meta-World)
CAGE_SCALE = (3.0, 3.0, 1.0)
# MTBench success target: the fully open handle (closed handle + 16 cm pull) = goal + (0, 0.2 - 0.16 - 0.01, 0)
SUCCESS_FROM_GOAL = (0.0, MAX_DIST - SLIDE_TRAVEL - 0.01, 0.0)
SUCCESS_RADIUS = 0.035


def drawer_open_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor,
                       init_tcp: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Meta-World v2 ``SawyerDrawerOpenEnvV3.compute_reward`` *without* its final ``* 5``.

    Returns ``(caging + opening, caging, opening)``, each ``[n]``; the first lies in [0, 2].
    """
    handle_error = (handle - goal).norm(dim=-1)
    opening = tolerance(handle_error, bounds=(0.0, 0.02), margin=MAX_DIST, sigmoid="long_tail")
    # Meta-World's handle_pos_init = target + (0, maxDist, 0) (1 cm behind the observed closed-handle point)
    handle_init = offset(goal, *(0.0, MAX_DIST, 0.0))
    gripper_error = scaled_norm(handle - tcp, CAGE_SCALE)
    gripper_error_init = scaled_norm(handle_init - init_tcp, CAGE_SCALE)
    caging = tolerance(gripper_error, bounds=(0.0, 0.01), margin=gripper_error_init, sigmoid="long_tail")
    return caging + opening, caging, opening


def drawer_open_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − fully-open handle‖ ≤ 0.035`` (see :class:`..drawer_open.DrawerOpen`)."""
    target = offset(goal, *SUCCESS_FROM_GOAL)
    return (handle - target).norm(dim=-1) <= SUCCESS_RADIUS


def scaled_norm(x: torch.Tensor, scale: tuple[float, float, float]) -> torch.Tensor:
    """``‖x · scale‖`` over the last axis (``[..., 3]``)."""
    return torch.stack([x[..., 0] * scale[0], x[..., 1] * scale[1], x[..., 2] * scale[2]], dim=-1).norm(dim=-1)


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
