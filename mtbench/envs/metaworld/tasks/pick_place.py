"""Pick-place: grasp a puck from the table and hold it at a goal in the air (Meta-World ``pick-place-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState
from ._grasp import grasped_and_lifted

TARGET_RADIUS = 0.05


def pick_place_reward(action: torch.Tensor, obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                      left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor,
                      obj_init_pos: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's dense term (see :class:`PickPlace`); points ``[n, 3]``, ``gripper_open`` ``[n]``, actions
    ``[n, 4]``."""
    obj_to_target = (obj - goal).norm(dim=-1)
    tcp_to_obj = (obj - tcp).norm(dim=-1)
    in_place = tolerance(obj_to_target, bounds=(0.0, TARGET_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    lifted = grasped_and_lifted(tcp_to_obj, gripper_open, obj[:, 2], obj_init_pos[:, 2], 0.02)
    return torch.where(lifted, reward + 1.0 + 5.0 * in_place, reward)


def pick_place_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class PickPlace(FreeObjectTask):
    """Pick up the red puck (cylinder, radius 2 cm, height 4 cm, 0.75 kg) and bring it to the goal.

    Scene and reset: Meta-World ``sawyer_pick_place_v3.xml``; puck ~ U([-0.1, 0.6, 0.02], [0.1, 0.7, 0.02]),
    goal ~ U([-0.1, 0.8, 0.05], [0.1, 0.9, 0.3]); pairs closer than 15 cm in xy are resampled (up to 8 times,
    Meta-World loops). Object observation: puck body position and quaternion (wxyz); no second object.

    Dense reward (paper-era MTBench ``task_fns/pick_place.py``, before its ``* 0.01``; 0..7)::

        in_place = tolerance(‖obj − goal‖, (0, 0.05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01,
                               xz_thresh=0.005, medium_density=True)
        r = hamacher(grasp, in_place)
        if ‖tcp − obj‖ < 0.02 and the gripper is not fully closed and obj_z − 0.01 > obj_init_z:  r += 1 + 5·in_place

    MTBench tests "not fully closed" as ``(q_finger1 + q_finger2) / 0.08 > 0``; the pad distance > 0 used here is
    the same condition. (Meta-World v2 uses its own pick-place caging variant with the pads' initial positions.)

    Success (paper-era MTBench): ``‖obj − goal‖ < 0.05`` (Meta-World: ``≤ 0.07``).
    """

    name = "pick_place"
    mtbench_id = 31
    description = "Pick up a puck and place it at a goal position in the air."
    scene = SceneSpec("sawyer_pick_place_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # puck x, y, z then goal x, y, z (Meta-World pick-place-v3 ranges)
    reset_low = (-0.1, 0.6, 0.02, -0.1, 0.8, 0.05)
    reset_high = (0.1, 0.7, 0.02, 0.1, 0.9, 0.3)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return pick_place_reward(action, s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad, s.goal,
                                 s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return pick_place_success(s.obj_pos, s.goal)
