"""Sweep: move a wooden block across the table to a goal 40 cm to the right (Meta-World ``sweep-v3``; paper-era
MTBench ``task_fns/sweep.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, Objects, TaskState, offset

TARGET_RADIUS = 0.05
BLOCK_HALF = 0.02  # the block is a 4 cm cube; its body origin is the centre of its bottom face
GOAL_X = 0.4  # MTBench: goal y_mtb = -0.4, i.e. x = 0.4 here


def sweep_reward(action: torch.Tensor, obj: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                 right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                 init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`Sweep`): ``obj`` is the block centre, points ``[n, 3]``, actions ``[n, 4]``."""
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    return 8.0 * hamacher_product(grasp, in_place) + 2.0 * in_place


def sweep_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖block − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class Sweep(FreeObjectTask):
    """Move the 4 cm wooden block (0.1 kg) lying on the table to a goal 40 cm to its right (+x).

    Scene: Meta-World ``sawyer_sweep_v3.xml``; the block's body origin is the centre of its bottom face, the
    observed and rewarded point is its centre (site ``obj``, body + (0, 0, 0.02)), as MTBench's block root.

    Reset (MTBench ranges mapped to this frame, ``x = -y_mtb, y = x_mtb + 0.6, z = z_mtb - 1.027``): block centre
    ~ U([-0.1, 0.6, 0.02], [0.1, 0.7, 0.02]) (Meta-World's range); goal = (0.4, block y, 0.02): MTBench samples
    the goal at y_mtb = -0.4 and then copies the block's x_mtb into it, i.e. the goal is 40 cm to the right of
    the block at the block's centre height. (Meta-World: goal x in [0.49, 0.51], z in [0, 0.02]; MTBench moved
    it to 0.4.) No goal rejection (none in MTBench; the goal is always >= 30 cm away).
    Object observation: block centre and quaternion (wxyz); no second object.

    Reward: MTBench's dense term (before its ``* .01``, ``dense_scale``)::

        in_place = tolerance(‖obj − goal‖, (0, 0.05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0,
                               xz_thresh=0.005, medium_density=True)
        r = 8·hamacher(grasp, in_place) + 2·in_place

    (Meta-World v2: ``2·grasp + 6·hamacher(grasp, in_place)`` with its own caging variant.)
    Success (MTBench): ``‖obj − goal‖ < 0.05``; success steps pay 20 (MTBench's sweep bonus).
    """

    name = "sweep"
    mtbench_id = 47
    description = "Sweep a puck off the edge of the table."
    scene = SceneSpec("sawyer_sweep_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # block centre x, y, z then goal x, y, z (the goal's y is replaced by the block's in reset)
    reset_low = (-0.1, 0.6, BLOCK_HALF, GOAL_X, 0.6, BLOCK_HALF)
    reset_high = (0.1, 0.7, BLOCK_HALF, GOAL_X, 0.7, BLOCK_HALF)
    MIN_GOAL_DIST = 0.0  # MTBench: no goal rejection
    success_bonus = 20.0

    def bind(self, model) -> None:
        self.obj_body = self.body_id("obj")
        self.obj_qpos = self.body_qposadr(self.obj_body)
        self.obj_site = self.site_id("obj")

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        obj = vec[:, :3]
        goal = torch.stack([vec[:, 3], obj[:, 1], vec[:, 5]], dim=-1)
        self.set_free_body(s.sim, self.obj_qpos, offset(obj, 0.0, 0.0, -BLOCK_HALF), mask)
        self.masked_set(s.obj_init_pos, obj, mask)
        self.masked_set(s.goal, goal, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.site_xpos[:, self.obj_site], s.sim.xquat[:, self.obj_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return sweep_reward(action, s.obj_pos, s.tcp, s.left_pad, s.right_pad, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return sweep_success(s.obj_pos, s.goal)
