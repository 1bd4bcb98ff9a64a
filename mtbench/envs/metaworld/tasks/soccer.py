"""Soccer: get a ball into the goal (Meta-World ``soccer-v3``; paper-era MTBench ``task_fns/soccer.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState, offset

TARGET_RADIUS = 0.07
SCALE = (3.0, 1.0, 1.0)  # MTBench (1, 3, 1) on (x_mtb, y_mtb, z): the lateral error counts three times
TARGET_FROM_GOAL = (0.0, -0.1, 0.013)  # MTBench: goal + (-0.1, 0, 0.013) in its frame
MTB_Y0 = 0.6  # y = x_mtb + 0.6


def _scaled_norm(x: torch.Tensor) -> torch.Tensor:
    return torch.stack([x[:, 0] * SCALE[0], x[:, 1] * SCALE[1], x[:, 2] * SCALE[2]], dim=-1).norm(dim=-1)


def soccer_reward(action: torch.Tensor, obj: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                  right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                  init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`Soccer`): ``goal`` is the target point in front of the goal mouth."""
    target_to_obj = _scaled_norm(obj - goal)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS), margin=_scaled_norm(obj - obj_init_pos),
                         sigmoid="long_tail")
    # past the goal line (the target's y) but more than 10 cm to the side: penalised, with MTBench's x_mtb
    # normalisation (obj_x_mtb - line) / (1 - line) written in this frame (x_mtb = y - 0.6)
    line = goal[:, 1]
    wide = (obj[:, 1] >= line) & ((obj[:, 0] - goal[:, 0]).abs() > 0.1)
    penalised = (in_place - 2.0 * (obj[:, 1] - line) / (1.0 + MTB_Y0 - line)).clamp(0.0, 1.0)
    in_place = torch.where(wide, penalised, in_place)
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.013, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    return 3.0 * grasp + 6.5 * in_place


def soccer_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖(ball − target)·(3, 1, 1)‖ < 0.07``."""
    return _scaled_norm(obj - goal) < TARGET_RADIUS


class Soccer(FreeObjectTask):
    """Bring the soccer ball (sphere, radius 2.6 cm, 40 g) to the target in front of the goal's mouth.

    Scene: Meta-World ``sawyer_soccer.xml``; the goal frame (``goal_whole``, fixed to the world; mouth 18 cm wide
    and 15.4 cm high, 6.4 cm in front of its origin) is moved per world with ``set_body_pos``.

    Reset (MTBench ranges mapped to this frame, ``x = -y_mtb, y = x_mtb + 0.6, z = z_mtb - 1.027``; equal to
    Meta-World's): ball ~ U([-0.1, 0.6, 0.03], [0.1, 0.7, 0.03]) (dropped 4 mm onto the table), goal frame
    ~ U([-0.1, 0.8, 0], [0.1, 0.9, 0]). No goal rejection (MTBench has none; Meta-World resamples pairs closer
    than 15 cm). The observed goal is MTBench's target, goal frame + (0, -0.1, 0.013): 3.6 cm in front of the
    mouth (Meta-World's target is the goal frame itself, at the back of the net).
    Object observation: ball position and quaternion (wxyz); no second object (as Meta-World).

    Reward: MTBench's dense term (before its ``* .01``), with ``d(a, b) = ‖(a − b)·(3, 1, 1)‖``::

        in_place = tolerance(d(ball, target), (0, 0.07), margin=d(ball, ball_init), long_tail)
        if ball_y >= target_y and |ball_x − target_x| > 0.1:
            in_place = clip(in_place − 2·(ball_y − target_y)/(1.6 − target_y), 0, 1)
        grasp = gripper_caging(obj_radius=0.013, pad_success_thresh=0.05, object_reach_radius=0.01,
                               xz_thresh=0.005, medium_density=True)
        r = 3·grasp + 6.5·in_place

    The margin ``d(ball, ball_init)`` is the ball's own displacement (as in both MTBench and Meta-World). The goal
    line is MTBench's target x_mtb (= Meta-World's goal - 0.1) and MTBench divides by ``1 − line`` in its frame,
    which is ``1.6 − line_y`` here. Meta-World uses its default caging (no medium density).
    Success (MTBench and Meta-World, with MTBench's target): ``d(ball, target) < 0.07``.
    """

    name = "soccer"
    mtbench_id = 43
    description = "Kick a soccer ball into the goal."
    scene = SceneSpec("sawyer_soccer.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # ball x, y, z then goal frame x, y, z
    reset_low = (-0.1, 0.6, 0.03, -0.1, 0.8, 0.0)
    reset_high = (0.1, 0.7, 0.03, 0.1, 0.9, 0.0)
    MIN_GOAL_DIST = 0.0  # MTBench: no goal rejection
    OBJ_BODY = "soccer_ball"

    def bind(self, model) -> None:
        self.obj_body = self.body_id(self.OBJ_BODY)
        self.obj_qpos = self.body_qposadr(self.obj_body)
        self.goal_body = self.body_id("goal_whole")

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.set_body_pos(s.sim, self.goal_body, vec[:, 3:6], mask)
        self.place(s, vec[:, :3], offset(vec[:, 3:6], *TARGET_FROM_GOAL), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return soccer_reward(action, s.obj_pos, s.tcp, s.left_pad, s.right_pad, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return soccer_success(s.obj_pos, s.goal)
