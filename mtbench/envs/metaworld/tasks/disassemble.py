"""Disassemble: lift a round nut up and off the peg it sits on (Meta-World ``disassemble-v3``; paper-era MTBench
``task_fns/disassemble.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import grasp_place_reward, gripper_caging_reward, tolerance
from ..scene import SceneSpec
from ..task import MetaWorldTask, TaskState, offset
from ._nut import HANDLE_OFFSET, XML, NutSceneMixin, wrench_threshed

SUCCESS_TOL = 0.05  # MTBench: |ring_z − target_z| < 0.05
LIFT_Z = 0.02  # "lifted": ring centre above the table + 2 cm
TARGET_ABOVE_RING = 0.15  # MTBench target = nut position + (0, 0, 0.15)
PEG_ABOVE_RING = 0.025  # MTBench peg centre = nut position + (0, 0, 0.025): the peg stands on the table


def disassemble_reward(action: torch.Tensor, handle: torch.Tensor, ring: torch.Tensor, tcp: torch.Tensor,
                       left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor,
                       obj_init_pos: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`Disassemble`): ``handle`` the handle centre, ``ring`` the ring centre."""
    grab = gripper_caging_reward(
        action, wrench_threshed(handle, tcp), obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0,
        xz_thresh=0.005, left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos,
        init_tcp=init_tcp, medium_density=True,
    )
    pos_error = torch.stack([goal[:, 0] - ring[:, 0], goal[:, 1] - ring[:, 1], goal[:, 2] + 0.1 - ring[:, 2]],
                            dim=-1).norm(dim=-1)
    lifted = (ring[:, 2] > LIFT_Z).to(ring.dtype)
    in_place = 0.1 * lifted + 0.9 * tolerance(pos_error, bounds=(0.0, 0.02), margin=0.2, sigmoid="long_tail")
    return 2.0 * grab + 6.0 * in_place


V2_HOLD_RADIUS = 0.03  # v2: TCP within 3 cm of the handle centre


def disassemble_reward_v2(action: torch.Tensor, handle: torch.Tensor, ring: torch.Tensor, tcp: torch.Tensor,
                          left_pad: torch.Tensor, right_pad: torch.Tensor, gripper_open: torch.Tensor,
                          goal: torch.Tensor, handle_init: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..7): :func:`~..reward_utils.grasp_place_reward` (pick_place's
    form) with the handle as grasp point and the ring as object, hold radius 3 cm, and the carry measured by the ring's
    height below the goal, ``|goal_z − ring_z|`` (the success rule only looks at heights), from 15 cm at the start to
    the 5 cm of the success rule.

    Why: the paper-era reward pays 0.1 · 6 as soon as the ring centre is above 2 cm (it rests at 1.9 cm, so a
    nudge pays it) and the rest through a long-tail term centred 10 cm *above* the goal (margin 0.2), which
    hardly changes over the first 10 cm of lift; v2 pays the ring's way up (long-tail, from
    15 cm below the goal to the 5 cm of the success rule) once the handle is held and lifted.
    """
    rise = ring[:, 2] - handle_init[:, 2]
    carry, carry0 = (goal[:, 2] - ring[:, 2]).abs(), (goal[:, 2] - handle_init[:, 2]).abs()
    return grasp_place_reward(action, tcp, left_pad, right_pad, gripper_open, handle, handle_init, init_tcp,
                              rise, carry, carry0,
                              obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
                              hold_radius=V2_HOLD_RADIUS, place_radius=SUCCESS_TOL)


def disassemble_success(ring: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``|ring_z − goal_z| < 0.05``: the ring centre lifted more than 10 cm (to 12.5 cm above the table)."""
    return (ring[:, 2] - goal[:, 2]).abs() < SUCCESS_TOL


class Disassemble(NutSceneMixin, MetaWorldTask):
    """Lift the nut (see :mod:`._nut`) by its handle off the 10 cm peg it is threaded on.

    Reset (MTBench ranges mapped to this frame, ``x = -y_mtb, y = x_mtb + 0.6, z = z_mtb - 1.027``; equal to
    Meta-World's): nut position ~ U([0, 0.6, 0.025], [0.1, 0.75, 0.02501]), the nut flat with its ring centre
    there (it settles onto the table, 6 mm lower), the peg standing on the table through the ring (peg centre =
    nut position + (0, 0, 0.025); Meta-World floats it 5 mm higher). Goal = nut position + (0, 0, 0.15).
    MTBench also samples an unused goal vector; the reset vector here is the nut position only.
    ``obj_init_pos`` is MTBench's nut position + (0, -0.13, 0)_mtb, i.e. the handle centre at reset.
    Object observation: handle centre and nut quaternion (wxyz), as Meta-World; no second object (MTBench
    observed the peg there).

    Reward: MTBench's dense term (before its ``* .01``)::

        grab = gripper_caging(handle with x snapped to the TCP's within 1 cm, obj_radius=0.02,
                              pad_success_thresh=0.05, object_reach_radius=0, xz_thresh=0.005, medium_density)
        in_place = 0.1·[ring_z > 0.02] + 0.9·tolerance(‖goal + (0, 0, 0.1) − ring‖, (0, 0.02), margin=0.2,
                                                        long_tail)
        r = 2·grab + 6·in_place

    MTBench computes a quaternion term, ``max(0, 1 − ‖q − q0‖)``, but does not use it (Meta-World multiplies its
    reward by ``max(0, 1 − ‖q − q0‖/0.4)``). Success (MTBench): ``|ring_z − goal_z| < 0.05``, i.e. the ring centre between 12.5 and
    22.5 cm above the table: off the peg (its top is at 10 cm; the ring's underside is then 10.6 cm high).
    Meta-World: handle z above the goal z.
    ``reward_version="v2"``: :func:`disassemble_reward_v2` (pick_place's form on the handle, the ring's height as the path).
    """

    name = "disassemble"
    mtbench_id = 12
    description = "Grasp the nut by its handle and lift it up and off the peg."
    scene = SceneSpec(XML, hand_init_pos=(0.0, 0.4, 0.2))
    # nut position x, y, z
    reset_low = (0.0, 0.6, 0.025)
    reset_high = (0.1, 0.75, 0.02501)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        nut = vec[:, :3]
        self.place_nut(s, nut, mask)
        self.set_body_pos(s.sim, self.peg_body, offset(nut, 0.0, 0.0, PEG_ABOVE_RING), mask)
        self.masked_set(s.obj_init_pos, offset(nut, HANDLE_OFFSET, 0.0, 0.0), mask)
        self.masked_set(s.goal, offset(nut, 0.0, 0.0, TARGET_ABOVE_RING), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return disassemble_reward(action, s.obj_pos, self.ring_center(s), s.tcp, s.left_pad, s.right_pad, s.goal,
                                  s.obj_init_pos, s.init_tcp)

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return disassemble_reward_v2(action, s.obj_pos, self.ring_center(s), s.tcp, s.left_pad, s.right_pad,
                                     s.gripper_open, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return disassemble_success(self.ring_center(s), s.goal)
