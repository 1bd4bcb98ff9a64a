"""Push-back: move a block lying on the table backwards, towards the robot, to a goal on the table (Meta-World
``push-back-v3``, MTBench ``task_fns/push_back.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState

OBJ_Z = 0.02  # block centre resting on the table
TARGET_RADIUS = 0.05
NEAR_OBJECT = 0.02


def push_back_reward(action: torch.Tensor, obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                     left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                     init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`PushBack`); points ``[n, 3]``, ``gripper_open`` ``[n]``, actions ``[n, 4]``."""
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    near = ((obj - tcp).norm(dim=-1) < NEAR_OBJECT) & (gripper_open > 0)
    return torch.where(near, reward + 1.0 + 10.0 * in_place, reward)


def push_back_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class PushBack(FreeObjectTask):
    """Bring the wooden block (4 cm cube, 0.75 kg, rotation-locked by its huge inertia) back towards the robot.

    * Reset (MTBench ranges mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``; equal to Meta-World
      push-back-v3's): block x ~ U[-0.1, 0.1], y ~ U[0.8, 0.85], z = 0.02 (resting); goal x ~ U[-0.1, 0.1],
      y ~ U[0.6, 0.7], z ~ U[0.0199, 0.0201]. Pairs closer than 15 cm in xy are resampled (up to 8 times;
      Meta-World loops until they are not; MTBench does not resample).
    * Objects: the block's pose.
    * Dense reward (MTBench, before its ``× 0.01``)::

        in_place = tolerance(‖obj − goal‖, (0, .05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=.015, pad_success_thresh=.05, object_reach_radius=0,
                               xz_thresh=.005, medium_density=True)
        r = hamacher(grasp, in_place);  if ‖tcp − obj‖ < .02 and gripper_open > 0:  r += 1 + 10·in_place

      (MTBench's "modified condition from metaworld": Meta-World asks ‖tcp − obj‖ < .01, 0 < open < .55 and
      progress, and adds 1 + 5·in_place).
    * Success: ``‖obj − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``); the success reward is 20 (MTBench).
    """

    name = "push_back"
    mtbench_id = 37
    description = "Push a puck backward towards the robot to a goal position."
    scene = SceneSpec("sawyer_push_back_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    success_bonus = 20.0
    # block x, y, z then goal x, y, z
    reset_low = (-0.1, 0.8, OBJ_Z, -0.1, 0.6, 0.0199)
    reset_high = (0.1, 0.85, OBJ_Z, 0.1, 0.7, 0.0201)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return push_back_reward(action, s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad, s.goal,
                                s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return push_back_success(s.obj_pos, s.goal)
