"""Button press: push a horizontal button into its wall-mounted box (Meta-World ``button-press-v3``, MTBench id 6)."""

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

NEAR_BOUND = 0.05  # MTBench: near_button = tol(tcp_to_obj, (0, 0.05), ...)
SUCCESS_TOL = 0.01


def button_press_reward(tcp: torch.Tensor, obj: torch.Tensor, init_tcp: torch.Tensor, goal: torch.Tensor,
                        tcp_closed: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """MTBench ``button_press`` dense term before its ``* .01``: ``2 · H(tcp_closed, near_button)``, with
    ``near_button = tol(‖obj − tcp‖, (0, .05), margin ‖obj − init_tcp‖, long_tail)``. Returns ``(dense,
    button_pressed, ‖obj − tcp‖)``; ``button_pressed = tol(|obj_y − goal_y|, (0, .005), margin .06, long_tail)``
    feeds the success reward."""
    tcp_to_obj = (obj - tcp).norm(dim=-1)
    tcp_to_obj_init = (obj - init_tcp).norm(dim=-1)  # MTBench: the *current* button point
    obj_to_target = (obj[..., 1] - goal[..., 1]).abs()
    dense, pressed = button_terms(tcp_to_obj, tcp_to_obj_init, obj_to_target, tcp_closed, NEAR_BOUND)
    return dense, pressed, tcp_to_obj


def button_press_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``|obj_y − goal_y| <= 0.01``: the button pressed at least 5 cm of its 6 cm travel (``[n]`` bool)."""
    return (obj[..., 1] - goal[..., 1]).abs() <= SUCCESS_TOL


class ButtonPress(ButtonSceneMixin, MetaWorldTask):
    """Push the red button (facing the robot) 5 to 6 cm into its box.

    * Scene: Meta-World ``sawyer_button_press.xml`` (hand starts at Meta-World's (0, 0.4, 0.2)).
    * Reset (MTBench ``obj_low/obj_high`` (.2, -.1) .. (.3, .1) at table + .24/2, mapped ``x = -y_mtb``,
      ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): box at x ~ U[-0.1, 0.1], y ~ U[0.8, 0.9], z = 0.12 (its collision
      boxes then rest on the table). Meta-World v3 samples y in [0.85, 0.9] at z = 0.115; MTBench's range is kept.
    * Observation: object 1 = MTBench's ``buttonStart`` point (``button + (0, -0.1935, 0)``, the front face of the
      cap, site ``button_start``) and the button's quaternion; no object 2. ``obj_init_pos = box + (0, -0.1935, 0)``.
      Goal = ``obj_init_pos + (0, 0.06, 0)`` (MTBench: ``+0.06`` along x_mtb, the end of the travel).
    * Dense reward (MTBench ``compute_reward`` before ``* .01``, :func:`button_press_reward`):
      ``2 · H(1 − openness, near_button)`` with MTBench's openness ``‖pads‖ / 0.095``.
    * Success: ``|obj_y − goal_y| <= 0.01``. Success steps pay ``0.01 · dense + 16 · button_pressed`` when
      ``‖tcp − obj‖ < 0.07`` (MTBench keeps the dense term on button_press* success steps).
    * Differences: ``init_tcp`` is the TCP at each reset (MTBench captured it once at the first observation);
      MTBench's ``tolerance`` returns 0 inside the bounds whenever ``margin > 0`` (its ``torch.where`` keeps the
      0 of the ``margin == 0`` branch); ours is Meta-World's (1 inside the bounds).
    * Physics: the Panda's palm is 20 cm long along y (the pressing direction) and 3.7 cm above the TCP, so closed
      fingers cannot press more than about 3 cm before the palm meets the box; the scripted policy presses with the
      far (+y) finger of the open gripper, whose outer face is 6.6 cm ahead of the TCP (see its docstring).
    """

    name = "button_press"
    mtbench_id = 6
    description = "Push a button horizontally into the wall-mounted panel."
    scene = SceneSpec("sawyer_button_press.xml", hand_init_pos=(0.0, 0.4, 0.2))
    reset_low = (-0.1, 0.8, 0.12)
    reset_high = (0.1, 0.9, 0.12)

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
        return button_press_reward(s.tcp, s.obj_pos, s.init_tcp, s.goal, tcp_closed)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return self._terms(s)[0]

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_press_success(s.obj_pos, s.goal)

    def success_reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_success_reward(*self._terms(s), self.dense_scale)
