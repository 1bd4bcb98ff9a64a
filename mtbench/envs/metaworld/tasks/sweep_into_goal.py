"""Sweep into goal: move a block across a raised table top into a square hole (Meta-World ``sweep-into-v3``;
paper-era MTBench ``task_fns/sweep_into_goal.py``)."""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, Objects, TaskState, offset

TARGET_RADIUS = 0.05
TCP_RADIUS = 0.03  # MTBench success: the hand is still at the block
SURFACE_Z = 0.05  # top of the raised table (Meta-World's basic_scene_b); the hole's floor is the table plane z = 0
BLOCK_HALF = 0.02
# Meta-World's ``basic_scene_b.xml`` table top: four colliding boxes on ``tablelink`` (at (0, 0.6, 0)) around a
# 16 x 16 cm hole centred at (0, 0.84), 5 cm deep: (position in the tablelink frame, half sizes)
HOLE_TABLE_BOXES = (
    ((0.0, -0.12, 0.0), (0.08, 0.28, 0.05)),
    ((-0.39, 0.0, 0.0), (0.31, 0.4, 0.05)),
    ((0.39, 0.0, 0.0), (0.31, 0.4, 0.05)),
    ((0.0, 0.36, 0.0), (0.08, 0.04, 0.05)),
)


def sweep_into_goal_reward(action: torch.Tensor, obj: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                           right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                           init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`SweepIntoGoal`); points ``[n, 3]``, actions ``[n, 4]``."""
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    return 8.0 * hamacher_product(grasp, in_place) + 2.0 * in_place


def sweep_into_goal_success(obj: torch.Tensor, tcp: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05`` and ``‖tcp − obj‖ < 0.03``."""
    return ((obj - goal).norm(dim=-1) < TARGET_RADIUS) & ((tcp - obj).norm(dim=-1) < TCP_RADIUS)


class SweepIntoGoal(FreeObjectTask):
    """Bring the 4 cm wooden block (0.1 kg) from the raised table top into the hole in front of it.

    Scene: Meta-World's ``sawyer_table_with_hole.xml`` uses another base scene (``basic_scene_b.xml``: the table
    top made of four boxes around a hole, no retaining wall), which the framework's scene builder does not take
    (it expects one table box, which it replaces by a plane). The task therefore loads ``sawyer_sweep_v3.xml`` (the
    same table and block asset as MTBench's ``block.xml``) and ``edit_spec`` adds Meta-World's hole table to it:
    the four raised boxes of ``basic_scene_b`` (top at z = 0.05, ``HOLE_TABLE_BOXES``) around a 16 x 16 cm hole
    centred at (0, 0.84) whose floor is the table plane z = 0, Meta-World's hole floor height too. All heights are
    Meta-World's (the raised surface is at 0.05). The block's body origin is the centre of its bottom face; the
    observed and rewarded point is its centre (site ``obj``), MTBench's block root. (Meta-World's own block here is
    a 10 g box with locked rotation; MTBench used its 0.1 kg ``block.xml``, as here.)

    Reset (MTBench ranges mapped to this frame, ``x = -y_mtb, y = x_mtb + 0.6``): block centre ~ U([-0.1, 0.6],
    [0.1, 0.7]) at z = 0.07 (resting on the raised surface; MTBench: its "surface" + 0.02). Goal = (0, 0.84,
    0.0325): MTBench's goal is the hole centre at its ``_table_surface_pos`` height, 1.0325 m, which is 3.25 cm
    above the hole floor (its raised surface is at 1.05, the floor at 1.0); Meta-World's goal is (0, 0.84, 0.02).
    No goal rejection (MTBench has none; Meta-World resamples blocks closer than 15 cm to the goal).
    Object observation: block centre and quaternion (wxyz); no second object.

    Reward: MTBench's dense term (before its ``* .01``)::

        in_place = tolerance(‖obj − goal‖, (0, 0.05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0,
                               xz_thresh=0.005, medium_density=True)
        r = 8·hamacher(grasp, in_place) + 2·in_place

    Success (MTBench): ``‖obj − goal‖ < 0.05`` and ``‖tcp − obj‖ < 0.03``: the block down in the hole near its
    centre (resting on the floor it is 1.25 cm below the goal) with the hand at the block. Success steps pay 20
    (MTBench's bonus for this task). Meta-World: ``‖obj − (goal_x, goal_y, obj_z)‖ < 0.05`` only.
    """

    name = "sweep_into_goal"
    mtbench_id = 46
    description = "Sweep a puck across the table into a hole."
    scene = SceneSpec("sawyer_sweep_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # block centre x, y, z then goal x, y, z (MTBench: goal x_mtb 0.2399..0.2401, y_mtb -0.001..0.001)
    reset_low = (-0.1, 0.6, SURFACE_Z + BLOCK_HALF, -0.001, 0.8399, 0.0325)
    reset_high = (0.1, 0.7, SURFACE_Z + BLOCK_HALF, 0.001, 0.8401, 0.0325)
    MIN_GOAL_DIST = 0.0  # MTBench: no goal rejection
    success_bonus = 20.0

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Meta-World's hole table: the raised boxes of ``HOLE_TABLE_BOXES`` (colliding and visual)."""
        table = spec.body("tablelink")
        for pos, size in HOLE_TABLE_BOXES:
            table.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(pos), size=list(size), contype=0, conaffinity=1,
                           group=4, material="table_col")
            table.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(pos), size=list(size), contype=0, conaffinity=0,
                           group=1, material="table_wood")

    def bind(self, model) -> None:
        self.obj_body = self.body_id("obj")
        self.obj_qpos = self.body_qposadr(self.obj_body)
        self.obj_site = self.site_id("obj")

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        obj = vec[:, :3]
        self.set_free_body(s.sim, self.obj_qpos, offset(obj, 0.0, 0.0, -BLOCK_HALF), mask)
        self.masked_set(s.obj_init_pos, obj, mask)
        self.masked_set(s.goal, vec[:, 3:6], mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.site_xpos[:, self.obj_site], s.sim.xquat[:, self.obj_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return sweep_into_goal_reward(action, s.obj_pos, s.tcp, s.left_pad, s.right_pad, s.goal, s.obj_init_pos,
                                      s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return sweep_into_goal_success(s.obj_pos, s.tcp, s.goal)
