"""Stick pull: grasp a stick, hook it through a thermos' handle and pull the thermos to a goal (Meta-World
``stick-pull-v3``; paper-era MTBench ``task_fns/stick_pull.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._stick import INSERTION, SCENE, STICK_HALF, StickSceneMixin
from .stick_push import stick_grasped

TARGET_RADIUS = 0.05
SUCCESS_RADIUS = 0.12
HANDLE_Z = 0.11  # MTBench's insertion point height (its thermos.xml: 0.110; Meta-World's site: 0.132)
THERMOS_FROM_STICK = (0.3, 0.0)  # MTBench: thermos root = stick + (0, -0.3)_mtb, i.e. 30 cm right of the stick
YZ_SCALE = (1.0, 1.0, 2.0)


def _scaled_norm(x: torch.Tensor) -> torch.Tensor:
    return torch.stack([x[:, 0] * YZ_SCALE[0], x[:, 1] * YZ_SCALE[1], x[:, 2] * YZ_SCALE[2]], dim=-1).norm(dim=-1)


def stick_inserted(handle: torch.Tensor, end: torch.Tensor) -> torch.Tensor:
    """MTBench's ``_stick_is_inserted``: the stick's end at or past the handle point in x, within 4 cm of it in y
    and 2 cm in z."""
    return ((end[:, 0] >= handle[:, 0]) & ((end[:, 1] - handle[:, 1]).abs() <= 0.04)
            & ((end[:, 2] - handle[:, 2]).abs() <= 0.02))


def stick_pull_reward(action: torch.Tensor, stick: torch.Tensor, end: torch.Tensor, handle: torch.Tensor,
                      gripper_open: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor, right_pad: torch.Tensor,
                      goal: torch.Tensor, obj_init_pos: torch.Tensor, stick_init: torch.Tensor,
                      init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`StickPull`): ``stick`` the stick's centre, ``end`` its end, ``handle``
    MTBench's insertion point, ``obj_init_pos`` that point at reset, ``stick_init`` the stick's centre at reset."""
    stick_in_place = tolerance(_scaled_norm(stick - handle), bounds=(0.0, TARGET_RADIUS),
                               margin=_scaled_norm(stick_init - obj_init_pos), sigmoid="long_tail")
    stick_in_place_2 = tolerance((stick - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                                 margin=(stick_init - goal).norm(dim=-1), sigmoid="long_tail")
    container_in_place = tolerance((handle - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                                   margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasped = gripper_caging_reward(
        action, stick, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=stick_init, init_tcp=init_tcp,
        medium_density=True,
    )
    grasp_success = stick_grasped(stick, gripper_open, tcp, stick_init)
    grasped = torch.where(grasp_success, 1.0, grasped)
    in_place_and_grasped = hamacher_product(grasped, stick_in_place)
    inserted = grasp_success & stick_inserted(handle, end)
    reward = torch.where(grasp_success, 1.0 + in_place_and_grasped + 5.0 * stick_in_place, in_place_and_grasped)
    return torch.where(inserted, 1.0 + in_place_and_grasped + 5.0 + 10.0 * stick_in_place_2
                       + 10.0 * container_in_place, reward)


def stick_pull_success(stick: torch.Tensor, end: torch.Tensor, handle: torch.Tensor, gripper_open: torch.Tensor,
                       tcp: torch.Tensor, stick_init: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """Handle point within 12 cm of the goal, the stick grasped and lifted, and inserted in the handle."""
    near = (handle - goal).norm(dim=-1) <= SUCCESS_RADIUS
    return near & stick_grasped(stick, gripper_open, tcp, stick_init) & stick_inserted(handle, end)


class StickPull(StickSceneMixin, MetaWorldTask):
    """Hook the stick (see :mod:`._stick`) through the thermos' handle and drag the thermos to the goal.

    Reset (MTBench ranges mapped to this frame, ``x = -y_mtb, y = x_mtb + 0.6, z = z_mtb - 1.027``): stick centre
    ~ U([-0.1, 0.65, 0.02], [0, 0.75, 0.02]) (MTBench; Meta-World: y in [0.55, 0.65]), thermos body at stick +
    (0.3, 0, 0) on the table (MTBench places it relative to the stick; Meta-World keeps it at (0.2, 0.69)), goal
    ~ U([0.35, 0.5, 0.11], [0.45, 0.55, 0.11]) (MTBench; Meta-World: y in [0.45, 0.55], z = 0.02).
    The handle point is MTBench's insertion point, thermos + (0, -0.09, 0.11): the centre of the handle's opening
    in x-y, 3.6 cm above its lower arm (MTBench's thermos.xml puts its ``insertion`` body at height 0.110;
    Meta-World's ``insertion`` site, at 0.132, is the opening's centre). ``obj_init_pos`` is the handle point at
    reset. No rejection (MTBench has none; Meta-World's 10 cm rejection cannot trigger here).
    Object observation: stick centre and quaternion (wxyz); second object: Meta-World's ``insertion`` site.

    Reward: MTBench's dense term (before its ``* .01``; Meta-World uses 2 and 1 where MTBench has 10 and 10)::

        stick_in_place = tolerance(‖(stick − handle)·(1, 1, 2)‖, (0, 0.05),
                                   margin=‖(stick_init − handle_init)·(1, 1, 2)‖, long_tail)
        stick_in_place_2 = tolerance(‖stick − goal‖, (0, 0.05), margin=‖stick_init − goal‖, long_tail)
        container_in_place = tolerance(‖handle − goal‖, (0, 0.05), margin=‖handle_init − goal‖, long_tail)
        grasp_success = ‖stick − tcp‖ < 0.03 and gripper_open > 0 and stick_z − 0.01 > stick_init_z
        grasped = 1 if grasp_success else gripper_caging(stick, obj_radius=0.02, pad_success_thresh=0.05,
                                                         object_reach_radius=0, xz_thresh=0.005, medium_density)
        h = hamacher(grasped, stick_in_place)
        inserted = end_x >= handle_x and |end_y − handle_y| <= 0.04 and |end_z − handle_z| <= 0.02
        r = h;  if grasp_success: r = 1 + h + 5·stick_in_place
        if grasp_success and inserted: r = 1 + h + 5 + 10·stick_in_place_2 + 10·container_in_place

    Success (MTBench): ``‖handle − goal‖ <= 0.12`` and ``grasp_success`` and ``inserted`` (Meta-World allows
    6 cm in z for ``inserted`` and 2 cm for the grasp); success steps pay 20 (MTBench's bonus for this task).
    """

    name = "stick_pull"
    mtbench_id = 44
    description = "Grasp a stick and use it to pull a container to the goal."
    scene = SCENE
    # stick centre x, y, z then goal x, y, z
    reset_low = (-0.1, 0.65, STICK_HALF, 0.35, 0.5, HANDLE_Z)
    reset_high = (0.0, 0.75, STICK_HALF, 0.45, 0.55, HANDLE_Z)
    buffers = {"stick_init": (3,)}
    success_bonus = 20.0

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        stick, goal = vec[:, :3], vec[:, 3:6]
        thermos = torch.stack([stick[:, 0] + THERMOS_FROM_STICK[0], stick[:, 1] + THERMOS_FROM_STICK[1],
                               stick[:, 2] * 0.0], dim=-1)
        self.place(s, stick, thermos, mask)
        self.masked_set(s.obj_init_pos, offset(thermos, INSERTION[0], INSERTION[1], HANDLE_Z), mask)
        self.masked_set(s.buffers["stick_init"], stick, mask)
        self.masked_set(s.goal, goal, mask)

    def handle(self, s: TaskState) -> torch.Tensor:
        """MTBench's insertion point: Meta-World's ``insertion`` site lowered to ``HANDLE_Z``."""
        return offset(self.insertion(s), 0.0, 0.0, HANDLE_Z - INSERTION[2])

    def objects(self, s: TaskState) -> Objects:
        pos, quat = self.body_pose(s, self.stick_body)
        return Objects(pos, quat, self.insertion(s))

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return stick_pull_reward(action, s.obj_pos, self.stick_end(s), self.handle(s), s.gripper_open, s.tcp,
                                 s.left_pad, s.right_pad, s.goal, s.obj_init_pos, s.buffers["stick_init"],
                                 s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return stick_pull_success(s.obj_pos, self.stick_end(s), self.handle(s), s.gripper_open, s.tcp,
                                  s.buffers["stick_init"], s.goal)
