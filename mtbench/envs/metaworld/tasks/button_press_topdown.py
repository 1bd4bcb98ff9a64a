"""Button press top-down: push a red button on top of a box straight down (MTBench ``task_fns/button_press_topdown.py``,
Meta-World ``button-press-topdown-v3``).

Scene: Meta-World's ``sawyer_button_press_topdown.xml``. The button box is a fixed body placed per world (batched
``body_pos``; its static collision geoms move with it). The button is a slide joint (``btnbox_joint``, 6 cm of
travel, a weak spring holding it up) whose body moves straight down when pressed; it is guided by its joint alone,
with a stiff limit and an armature (see :mod:`._button`).

The task is ``button_press_topdown_wall`` without the wall (the two MTBench task files differ only in the wall):
same observed point (MTBench's ``buttonStart``, the top of the cap), goal (that point at the end of the 6 cm
travel), dense reward, success rule and success reward; see :mod:`.button_press_topdown_wall`.
"""

from __future__ import annotations

import torch

from ..reward_utils import mtbench_gripper_openness
from ..scene import SceneSpec
from ..task import MetaWorldTask, TaskState, offset
from ._button import START_OFFSET, TRAVEL, ButtonSceneMixin, button_success_reward, edit_button_scene
from .button_press_topdown_wall import button_press_topdown_wall_reward as button_press_topdown_reward
from .button_press_topdown_wall import button_press_topdown_wall_success as button_press_topdown_success


class ButtonPressTopdown(ButtonSceneMixin, MetaWorldTask):
    """Press the red button (pointing up) down through at least 5 of its 6 cm of travel.

    * Reset (MTBench ``obj_low/obj_high`` (.2, -.1) .. (.3, .1) at table + .24/2, mapped ``x = -y_mtb``,
      ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): box at x ~ U[-0.1, 0.1], y ~ U[0.8, 0.9], z = 0.12 (Meta-World:
      z = 0.115). ``obj_init_pos = box + (0, 0, 0.1935)`` (MTBench's ``buttonStart``), goal = ``obj_init_pos - (0, 0,
      0.06)``.
    * Observation: object 1 = the ``button_start`` site (the top of the cap) and the button's quaternion.
    * Dense reward (paper-era MTBench, before its ``* .01``): ``2 · H(1 − openness, near_button)``, ``near_button =
      tol(‖obj − tcp‖, (0, .05), margin ‖obj_init − init_tcp‖, long_tail)``, openness = pad distance / 0.095.
    * Success: ``|obj_z − goal_z| ≤ 0.01``. Success steps pay ``0.01 · dense + 16 · button_pressed`` while
      ``‖tcp − obj‖ < 0.07`` (MTBench's rule; not scaled by ``reward_scale``), ``button_pressed = tol(|obj_z −
      goal_z|, (0, .005), margin .06, long_tail)``.
    * Differences to Meta-World v2: its reward is ``5 · H(1 − openness, near_button(0.01)) + 5 · button_pressed``
      against the box's ``hole`` site and its success needs a 6.95 cm press (beyond the 6 cm travel). The hand
      starts at Meta-World's (0, 0.4, 0.2).
    """

    name = "button_press_topdown"
    mtbench_id = 4
    description = "Press a button downward from above."
    scene = SceneSpec("sawyer_button_press_topdown.xml", hand_init_pos=(0.0, 0.4, 0.2))
    reset_low = (-0.1, 0.8, 0.12)
    reset_high = (0.1, 0.9, 0.12)

    @classmethod
    def edit_spec(cls, spec) -> None:
        edit_button_scene(spec)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        box = vec[:, :3]
        self.place_box(s, box, mask)
        obj_init = offset(box, 0.0, 0.0, START_OFFSET)
        self.masked_set(s.obj_init_pos, obj_init, mask)
        self.masked_set(s.goal, offset(obj_init, 0.0, 0.0, -TRAVEL), mask)

    def _terms(self, s: TaskState) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        tcp_closed = 1.0 - mtbench_gripper_openness(s.left_pad, s.right_pad)
        return button_press_topdown_reward(s.tcp, s.obj_pos, s.obj_init_pos, s.init_tcp, s.goal, tcp_closed)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return self._terms(s)[0]

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_press_topdown_success(s.obj_pos, s.goal)

    def success_reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_success_reward(*self._terms(s), self.dense_scale)
