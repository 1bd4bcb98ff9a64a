"""Scripted assembly: grasp the nut's handle from above, lift the nut, carry its ring over the peg and lower it
down around the peg (the ring leaves 9 mm of radial clearance)."""

from __future__ import annotations

import torch

from ...rotations import quat_rotate
from ._common import action, parse
from ._grasp import move_lead, grasp_phase
from ._tools import with_z
from .disassemble import HANDLE_GRASP

RING_FROM_HANDLE_LOCAL = (0.0, 0.13, 0.0)  # ring centre relative to the handle in the nut's frame
TARGET_ABOVE_PEG_TOP = 0.05  # the observed goal is 5 cm above the peg's top
CARRY_Z = 0.16  # ring centre height while travelling (the ring's underside clears the peg's top by 4 cm)
INSERT_Z = 0.05  # lower the ring centre to here (half way down the peg)
ALIGNED = 0.004  # ring-to-peg x-y error under which the ring is lowered
CARRY_SPEED = 0.6
LOWER_SPEED = 0.4


def ring_center(handle: torch.Tensor, nut_quat: torch.Tensor) -> torch.Tensor:
    local = torch.zeros_like(handle)
    local[:, 1] = RING_FROM_HANDLE_LOCAL[1]
    return handle + quat_rotate(nut_quat, local)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, handle, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, handle, o["gripper_open"], **HANDLE_GRASP)
    ring = ring_center(handle, o["obj_quat"])
    peg_top_z = goal[:, 2] - TARGET_ABOVE_PEG_TOP
    xy_err = (ring[:, :2] - goal[:, :2]).norm(dim=-1)
    aligned = xy_err < ALIGNED
    # over the peg (within 1 cm) and below the carry height: keep going down while aligned
    lowering = (xy_err < 0.01) & (ring[:, 2] < CARRY_Z - 0.01)
    high_enough = ring[:, 2] > CARRY_Z - 0.02
    travel = with_z(goal, torch.full_like(goal[:, 2], CARRY_Z))
    rise = with_z(ring, torch.full_like(goal[:, 2], CARRY_Z))
    insert = with_z(goal, peg_top_z - (0.1 - INSERT_Z))
    ring_target = torch.where((aligned | lowering)[:, None], insert, torch.where(high_enough[:, None], travel, rise))
    target = torch.where(held[:, None], hand + ring_target - ring, target)
    speed = torch.where(held, torch.where(aligned | lowering, LOWER_SPEED, CARRY_SPEED), 1.0)
    delta = move_lead(hand, prev, target, speed=speed)
    return action(delta, torch.where(close, 1.0, -1.0))
