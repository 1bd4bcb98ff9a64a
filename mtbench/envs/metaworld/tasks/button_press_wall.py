"""Button press wall: push a horizontal button that stands behind a short wall (Meta-World ``button-press-wall-v3``,
MTBench id 7)."""

from __future__ import annotations

import torch

from ..reward_utils import mtbench_gripper_openness
from ..scene import SceneSpec
from ..task import MetaWorldTask, TaskState, offset
from ._button import (
    START_OFFSET,
    TRAVEL,
    ButtonSceneMixin,
    button_success_reward,
    button_terms,
    edit_button_scene,
)

NEAR_BOUND = 0.01  # MTBench (button_press_wall): near_button = tol(tcp_to_obj, (0, 0.01), ...)
WALL_OFFSET = (0.05, -0.30)  # wall (x, y) relative to the box (MTBench: box + (-.30, -.05) in its frame)
SUCCESS_TOL = 0.01


def button_press_wall_reward(tcp: torch.Tensor, obj: torch.Tensor, obj_init: torch.Tensor, init_tcp: torch.Tensor,
                             goal: torch.Tensor, tcp_closed: torch.Tensor
                             ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """MTBench ``button_press_wall`` dense term before its ``* .01``: ``2 · H(tcp_closed, near_button)``, with
    ``near_button = tol(‖obj − tcp‖, (0, .01), margin ‖obj_init − init_tcp‖, long_tail)``. Returns ``(dense,
    button_pressed, ‖obj − tcp‖)``; ``button_pressed = tol(|obj_y − goal_y|, (0, .005), margin .06, long_tail)``
    feeds the success reward."""
    tcp_to_obj = (obj - tcp).norm(dim=-1)
    tcp_to_obj_init = (obj_init - init_tcp).norm(dim=-1)
    obj_to_target = (obj[..., 1] - goal[..., 1]).abs()
    dense, pressed = button_terms(tcp_to_obj, tcp_to_obj_init, obj_to_target, tcp_closed, NEAR_BOUND)
    return dense, pressed, tcp_to_obj


def button_press_wall_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``|obj_y − goal_y| <= 0.01``: the button pressed at least 5 cm of its 6 cm travel (``[n]`` bool)."""
    return (obj[..., 1] - goal[..., 1]).abs() <= SUCCESS_TOL


class ButtonPressWall(ButtonSceneMixin, MetaWorldTask):
    """Push the red button (facing the robot) 5 to 6 cm into its box past a 15 cm wall standing in front of it.

    * Scene: Meta-World ``sawyer_button_press_wall.xml`` (hand starts at Meta-World's (0, 0.4, 0.2)).
    * Reset (MTBench ``obj_low/obj_high`` (.25, -.05) .. (.30, .05) at table + .24/2, mapped ``x = -y_mtb``,
      ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): box at x ~ U[-0.05, 0.05], y ~ U[0.85, 0.9], z = 0.12 (Meta-World
      v3: the same x-y range at z = 0.115). The wall follows the box as in MTBench (``wall = box + (-.30, -.05)``
      in MTBench's frame): wall body at ``box + (0.05, -0.30)`` on the table (Meta-World keeps it fixed at
      (0.1, 0.6)); it spans x ``box_x - 0.05 .. box_x + 0.15``, y ``box_y - 0.31 .. box_y - 0.29``, z 0 .. 0.15, so
      it stands 9.6 cm in front of the button's face and covers it.
    * Observation: object 1 = MTBench's ``buttonStart`` point (``button + (0, -0.1935, 0)``, site
      ``button_start``) and the button's quaternion; object 2 = the wall's centre (wall body + (0, 0, 0.075)) and
      quaternion (MTBench reports its wall actor's root plus 0.075 in z). ``obj_init_pos = box + (0, -0.1935, 0)``,
      goal = ``obj_init_pos + (0, 0.06, 0)`` (the end of the travel).
    * Dense reward (MTBench ``compute_reward`` before ``* .01``, :func:`button_press_wall_reward`):
      ``2 · H(1 − openness, near_button)``, near bound 0.01 (button_press: 0.05).
    * Success: ``|obj_y − goal_y| <= 0.01``. Success steps pay ``0.01 · dense + 16 · button_pressed`` when
      ``‖tcp − obj‖ < 0.07``.
    * Differences: as button_press (``init_tcp`` per reset, Meta-World's ``tolerance`` inside the bounds).
    * Physics: the hand has to reach over the wall: the scripted policy keeps the fingertips above the wall's top
      and presses the cap's upper edge with the open gripper's far finger.
    """

    name = "button_press_wall"
    mtbench_id = 7
    description = "Push a horizontal button on a panel that is partly hidden behind a short wall."
    scene = SceneSpec("sawyer_button_press_wall.xml", hand_init_pos=(0.0, 0.4, 0.2))
    reset_low = (-0.05, 0.85, 0.12)
    reset_high = (0.05, 0.9, 0.12)
    WALL_OFFSET = WALL_OFFSET

    @classmethod
    def edit_spec(cls, spec) -> None:
        edit_button_scene(spec)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        box = vec[:, :3]
        self.place_box(s, box, mask)
        obj_init = offset(box, 0.0, -START_OFFSET, 0.0)
        self.masked_set(s.obj_init_pos, obj_init, mask)
        self.masked_set(s.goal, offset(obj_init, 0.0, TRAVEL, 0.0), mask)

    def _terms(self, s: TaskState) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        tcp_closed = 1.0 - mtbench_gripper_openness(s.left_pad, s.right_pad)
        return button_press_wall_reward(s.tcp, s.obj_pos, s.obj_init_pos, s.init_tcp, s.goal, tcp_closed)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return self._terms(s)[0]

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_press_wall_success(s.obj_pos, s.goal)

    def success_reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_success_reward(*self._terms(s), self.dense_scale)
