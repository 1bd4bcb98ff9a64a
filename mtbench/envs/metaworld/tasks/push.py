"""Push: move a puck lying on the table to a goal on the table (Meta-World ``push-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState

OBJ_Z = 0.02  # puck centre height when resting on the table (Meta-World's obj_init_pos z)
TARGET_RADIUS = 0.05
TCP_RADIUS = 0.02  # MTBench success: hand still at the puck


def push_reward(action: torch.Tensor, obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's dense term (see :class:`Push`); points ``[n, 3]``, ``gripper_open`` ``[n]``, actions ``[n, 4]``."""
    tcp_to_obj = (obj - tcp).norm(dim=-1)
    target_to_obj = (obj - goal).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.0, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos,
        init_tcp=init_tcp, medium_density=True,
    )
    reward = 2.0 * grasp
    near = (tcp_to_obj < TCP_RADIUS) & (gripper_open > 0)
    return torch.where(near, reward + 1.0 + 5.0 * in_place, reward)


def push_success(obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                 goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05`` and ``‖tcp − obj‖ < 0.02`` and the gripper not fully closed."""
    near = ((obj - tcp).norm(dim=-1) < TCP_RADIUS) & (gripper_open > 0)
    return ((obj - goal).norm(dim=-1) < TARGET_RADIUS) & near


class Push(FreeObjectTask):
    """Push the red puck (cylinder, radius 2 cm, height 4 cm, 0.75 kg) to the green goal on the table.

    Scene and reset: Meta-World ``sawyer_push_v3.xml``; puck xy ~ U([-0.1, 0.6], [0.1, 0.7]) at z = 0.02 (resting
    on the table), goal xy ~ U([-0.1, 0.8], [0.1, 0.9]) at the puck's height (Meta-World replaces the sampled goal
    z by the puck's z); pairs closer than 15 cm in xy are resampled (up to 8 times, Meta-World loops until they
    are not). Object observation: puck body position and quaternion (wxyz); no second object.

    Dense reward (paper-era MTBench ``task_fns/push.py``, before its ``* 0.01``; 0..8)::

        in_place = tolerance(‖obj − goal‖, (0, 0.05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=0, pad_success_thresh=0.05, object_reach_radius=0.01,
                               xz_thresh=0.005, medium_density=True)
        r = 2·grasp;  if ‖tcp − obj‖ < 0.02 and gripper_open > 0:  r += 1 + 5·in_place

    (Meta-World v2 uses ``obj_radius=0.015, high_density`` and doubles the caging term.)

    Success (paper-era MTBench): ``‖obj − goal‖ < 0.05`` and ``‖tcp − obj‖ < 0.02`` and the gripper not fully
    closed (the hand must still be at the puck); Meta-World only asks ``‖obj − goal‖ ≤ 0.05``. All distances are
    frame invariant.
    """

    name = "push"
    mtbench_id = 38
    description = "Push a puck across the table to a goal position."
    scene = SceneSpec("sawyer_push_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # puck x, y, z then goal x, y, z (Meta-World push-v3 ranges)
    reset_low = (-0.1, 0.6, 0.02, -0.1, 0.8, 0.01)
    reset_high = (0.1, 0.7, 0.02, 0.1, 0.9, 0.02)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        z = torch.full_like(vec[:, :1], OBJ_Z)  # a fill, no host-to-device copy
        self.place(s, torch.cat([vec[:, :2], z], dim=-1), torch.cat([vec[:, 3:5], z], dim=-1), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return push_reward(action, s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad, s.goal,
                           s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return push_success(s.obj_pos, s.gripper_open, s.tcp, s.goal)
