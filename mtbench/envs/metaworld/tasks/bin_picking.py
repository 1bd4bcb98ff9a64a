"""Bin picking: pick a cube out of the red bin and place it in the blue bin (Meta-World ``bin-picking-v3``;
paper-era MTBench ``task_fns/bin_picking.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState, offset

TARGET_RADIUS = 0.05
NEAR_RADIUS = 0.04  # MTBench's near_object
LIFT = 0.02  # MTBench's "lifted": 2 cm above the initial height
SPAWN_ABOVE = 0.02  # MTBench drops the cube from obj_init_pos + (0, 0, 0.02)


def bin_picking_reward(action: torch.Tensor, obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                       left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor,
                       obj_init_pos: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`BinPicking`); points ``[n, 3]``, ``gripper_open`` ``[n]``, actions ``[n, 4]``."""
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    near = (obj - tcp).norm(dim=-1) < NEAR_RADIUS
    lifted = obj[:, 2] - LIFT > obj_init_pos[:, 2]
    grasp_success = near & lifted & (gripper_open > 0)
    return torch.where(grasp_success, reward + 1.0 + 5.0 * in_place, reward)


def bin_picking_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class BinPicking(FreeObjectTask):
    """Move the green 4 cm cube (0.1 kg) from the red bin (at (-0.12, 0.7)) into the blue bin (at (0.12, 0.7)).

    Scene: Meta-World ``sawyer_bin_picking.xml``; both bins (20 x 20 cm, 6 cm high walls, floor top at z = 0.01)
    stay at their XML positions, which are MTBench's (``binA``/``binB`` at x_mtb 0.1, y_mtb ±0.12).

    Reset (MTBench ranges mapped to this frame, ``x = -y_mtb, y = x_mtb + 0.6, z = z_mtb - 1.027``):
    ``obj_init_pos`` ~ U([-0.15, 0.65, 0.02], [-0.15, 0.75, 0.02]) and the cube is dropped from 2 cm above it
    (it comes to rest on the bin floor with its centre at 0.03). MTBench fixed the cube's lateral position
    ("changed to (.15,.15) to make the cube centered"; Meta-World: x in [-0.21, -0.03]). Goal ~ U([0.1199, 0.699,
    0.05], [0.1201, 0.701, 0.05]): the centre of the blue bin 5 cm above the table (Meta-World: the bin body at
    z = 0). Object observation: cube position and quaternion (wxyz); no second object (as Meta-World).

    Reward: MTBench's dense term (before its ``* .01``; MTBench dropped Meta-World's above-floor funnel)::

        in_place = tolerance(‖obj − goal‖, (0, 0.05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0,
                               xz_thresh=0.005, medium_density=True)
        r = hamacher(grasp, in_place)
        if ‖obj − tcp‖ < 0.04 and obj_z − 0.02 > obj_init_z and gripper_open > 0:  r += 1 + 5·in_place

    Success (MTBench and Meta-World): ``‖obj − goal‖ < 0.05`` (a cube resting in the blue bin is 2 cm below the
    goal, so it counts within 4.6 cm of the bin centre).
    """

    name = "bin_picking"
    mtbench_id = 2
    description = "Pick a small cube out of one bin and place it into the other bin."
    scene = SceneSpec("sawyer_bin_picking.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # obj_init x, y, z then goal x, y, z
    reset_low = (-0.15, 0.65, 0.02, 0.1199, 0.699, 0.05)
    reset_high = (-0.15, 0.75, 0.02, 0.1201, 0.701, 0.05)
    MIN_GOAL_DIST = 0.0  # MTBench: no rejection (the bins are 24 cm apart)

    def bind(self, model) -> None:
        self.obj_body = self.body_id("obj")
        self.obj_qpos = self.body_qposadr(self.obj_body)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.set_free_body(s.sim, self.obj_qpos, offset(vec[:, :3], 0.0, 0.0, SPAWN_ABOVE), mask)
        self.masked_set(s.obj_init_pos, vec[:, :3], mask)
        self.masked_set(s.goal, vec[:, 3:6], mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return bin_picking_reward(action, s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad, s.goal,
                                  s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return bin_picking_success(s.obj_pos, s.goal)
