"""Door open: swing a hinged safe door open by its handle (MTBench ``task_fns/door_open.py``, Meta-World
``door-open-v3``).

Scene: see :mod:`._door` (Meta-World's ``sawyer_door_pull.xml``, ``doorlockB``). All of the door's collision geoms
have ``contype = conaffinity = 1``, so the Panda collides with the handle, the panel and the safe.

Dense reward (paper-era MTBench, before its ``* .01``), with ``handle`` = MTBench's handle point (site
``handle_point``) and heights measured from the table top (MTBench's ``TABLE_Z``)::

    door           = handle + (0.075, -0.15, 0)        # MTBench: handle + (-.15, -.075) in its frame
    radius         = ‖tcp_xy − door_xy‖
    floor          = 0 if radius ≤ 0.12 else 0.04 · log(radius − 0.12) + 0.25      # a funnel around the handle
    above_floor    = 1 if tcp_z ≥ floor else tolerance(floor − tcp_z, (0, 0.01), margin=0.1, long_tail)
    in_place       = tolerance(‖tcp − door + (0, 0, 0.01)‖, (0, 0.06), margin=0.5, long_tail)
    ready_to_open  = hamacher(above_floor, in_place)
    opened         = 0.2 · [theta < −π/90] + 0.8 · tolerance(π/2 + π/6 + theta, (0, 0.5), margin=π/3, long_tail),
                     = 1 when the door is open by more than 1.5 rad
    r = 2 · hamacher(ready_to_open, tcp_opened) + 8 · opened

with ``theta`` the hinge angle (negative = open) and ``tcp_opened`` = pad distance / 0.095 clipped to [0, 1]
(MTBench rewards an *open* gripper here; Meta-World v2 rewards the closing effort).

``reward_version="v2"``: :func:`door_open_reward_v2` (reach the handle bar, then the push point on the panel's inner
face once the door is open by 0.6 rad, plus linear pay for the door angle).

Success (MTBench ``|door_y − target_y| ≤ 0.08`` in its frame, whose y axis is our −x and whose ``door`` is the
handle point): ``|handle_x − goal_x| ≤ 0.08`` with goal = safe + (−0.3, −0.45, 0) (MTBench's target
``root + (−.45, .3, 0)``). With the handle point at ``door_link + (0.325, −0.062, 0)`` this holds for hinge angles in
[−2, −1.49] rad (door opened 85 degrees up to its 115-degree limit).

Reset (MTBench ``obj_low/obj_high`` (.35, −.1) .. (.45, 0) at table + .3/2): safe at x ~ U[0, 0.1],
y ~ U[0.95, 1.05], z = 0.15 (Meta-World v3: y in [0.85, 0.95]; MTBench moved the safe 10 cm back), door closed.

Differences: the hand starts at Meta-World's TCP position (0, 0.6, 0.2); ``init_tcp`` is recorded at every reset
(MTBench: once). The safe's own collision geoms move with it (``WarpSim.set_body_pos``).
"""

from __future__ import annotations

import math

import mujoco
import torch

from ..reward_utils import hamacher_product, mtbench_gripper_openness, tolerance
from ..scene import SceneSpec
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._door import (DOOR_BODY, DOOR_JOINT, HANDLE_SITE, PUSH, PUSH_Z, SAFE_BODY, door_point, edit_door_scene,
                    hook_tcp)

GOAL_OFFSET = (-0.3, -0.45, 0.0)  # goal relative to the safe (MTBench's target_pos)
REACH_OFFSET = (0.075, -0.15, 0.0)  # MTBench's ``door`` point relative to the handle point
FUNNEL_RADIUS = 0.12
SUCCESS_TOL = 0.08
V2_SWITCH_ANGLE = 0.6  # rad: below it the hand should hook the bar (``_door.HOOK``), from it push the panel (``PUSH``)
V2_REACH_RADIUS = 0.05
V2_REACH_MARGIN = 0.3  # about the hand's start -> hook and hook -> push point distances
V2_OPEN_ANGLE = 1.5  # rad: ``opened`` is 1 from here (success needs 1.49)


def door_open_reward(tcp: torch.Tensor, handle: torch.Tensor, theta: torch.Tensor,
                     tcp_opened: torch.Tensor) -> torch.Tensor:
    """MTBench's door-open dense term (``[n]``, 0..10; see the module docstring); pure function of tensors."""
    door = offset(handle, *REACH_OFFSET)
    radius = (tcp[..., :2] - door[..., :2]).norm(dim=-1)
    funnel = 0.04 * torch.log((radius - FUNNEL_RADIUS).clamp_min(1e-12)) + 0.25
    floor = torch.where(radius <= FUNNEL_RADIUS, torch.zeros_like(radius), funnel)
    above_floor = tolerance(floor - tcp[..., 2], bounds=(0.0, 0.01), margin=0.1, sigmoid="long_tail")
    above_floor = torch.where(tcp[..., 2] >= floor, torch.ones_like(above_floor), above_floor)
    in_place = tolerance(offset(tcp - door, 0.0, 0.0, 0.01).norm(dim=-1), bounds=(0.0, 0.06), margin=0.5,
                         sigmoid="long_tail")
    ready_to_open = hamacher_product(above_floor, in_place)
    door_angle = -theta
    opened = 0.2 * (theta < -math.pi / 90.0).to(tcp.dtype) + 0.8 * tolerance(
        math.pi / 2.0 + math.pi / 6.0 - door_angle, bounds=(0.0, 0.5), margin=math.pi / 3.0, sigmoid="long_tail")
    opened = torch.where(door_angle > 1.5, torch.ones_like(opened), opened)
    return 2.0 * hamacher_product(ready_to_open, tcp_opened) + 8.0 * opened


def door_open_reward_v2(tcp: torch.Tensor, hinge: torch.Tensor, theta: torch.Tensor) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..8), with ``hinge`` the door body's origin (the hinge at the
    handle's height) and ``a = −theta`` the door angle (0 closed)::

        hook   = hinge + R(theta)·(0.40, −0.071) − (0, 0.054, 0)       # TCP of the open gripper round the bar
        push   = (hinge + R(theta)·(0.33, 0.055), z 0.25)                 # TCP beside the panel's inner face
        reach(p) = tolerance(‖tcp − p‖, (0, .05), margin=.3, long_tail)
        opened = clamp(a / 1.5, 0, 1)
        r = reach(hook) + 6·opened              while a < 0.6
        r = 1 + reach(push) + 6·opened          from a = 0.6 on

    Why: the paper-era reward's hand term pays 2 at a fixed point in front of the handle, which MT-PPO on MT50-rand
    learns to park the open gripper at after pulling the door to ~0.9 rad (the bar then leaves the hand's
    workspace; 0% success). Finishing needs the hand beside the panel's inner face pushing it on (the scripted
    controller's phase B), and the paper-era reward pays nothing for getting there while taking away the 2 of the
    parking spot. Here the reach target follows the door: the bar while pulling, the push point from 0.6 rad on;
    the second stage's floor of 1 keeps the switch from lowering the reward (``reach(hook) ≤ 1``), every step of the
    hand towards the push point pays, and opening pays 4 per radian all the way. At the parking spot (door at
    0.97 rad) this pays 5.1, with the hand at the push point 5.9, finished 8 (the paper-era formula with the correct
    ``tolerance``: 5.1 parked, 3.1 at the push point); along the scripted controller's path no step loses more
    than 0.05.
    """
    z = hinge[..., 2:3]
    hook = torch.cat([hook_tcp(hinge, theta), z], dim=-1)
    push = torch.cat([door_point(hinge, theta, PUSH), torch.full_like(z, PUSH_Z)], dim=-1)

    def reach(target: torch.Tensor) -> torch.Tensor:
        return tolerance((tcp - target).norm(dim=-1), bounds=(0.0, V2_REACH_RADIUS), margin=V2_REACH_MARGIN,
                         sigmoid="long_tail")

    angle = -theta
    opened = (angle / V2_OPEN_ANGLE).clamp(0.0, 1.0)
    staged = torch.where(angle < V2_SWITCH_ANGLE, reach(hook), 1.0 + reach(push))
    return staged + 6.0 * opened


def door_open_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``|handle_x − goal_x| ≤ 0.08`` (MTBench's rule in our frame; ``[n]`` bool)."""
    return (handle[..., 0] - goal[..., 0]).abs() <= SUCCESS_TOL


class DoorOpen(MetaWorldTask):
    """Swing the safe door open by about 90 degrees (see the module docstring).

    Observation: object 1 = MTBench's handle point and the door's quaternion; goal = safe + (−0.3, −0.45, 0).
    ``reward_version="v2"``: :func:`door_open_reward_v2` (hook the bar, then push the panel's inner face).
    """

    name = "door_open"
    mtbench_id = 16
    description = "Grab the door handle and swing the door open on its hinges."
    scene = SceneSpec("sawyer_door_pull.xml", hand_init_pos=(0.0, 0.6, 0.2))
    reset_low = (0.0, 0.95, 0.15)
    reset_high = (0.1, 1.05, 0.15)

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        edit_door_scene(spec)

    def bind(self, model) -> None:
        self.safe_body = self.body_id(SAFE_BODY)
        self.door_body = self.body_id(DOOR_BODY)
        self.door_qpos = self.joint_qposadr(DOOR_JOINT)
        self.handle_site = self.site_id(HANDLE_SITE)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        safe = vec[:, :3]
        self.set_body_pos(s.sim, self.safe_body, safe, mask)
        self.set_joint(s.sim, self.door_qpos, 0.0, mask)
        self.masked_set(s.goal, offset(safe, *GOAL_OFFSET), mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        self.masked_set(s.obj_init_pos, s.obj_pos, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.site_xpos[:, self.handle_site], s.sim.xquat[:, self.door_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        tcp_opened = mtbench_gripper_openness(s.left_pad, s.right_pad)
        return door_open_reward(s.tcp, s.obj_pos, s.sim.qpos[:, self.door_qpos], tcp_opened)

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_open_reward_v2(s.tcp, s.sim.xpos[:, self.door_body], s.sim.qpos[:, self.door_qpos])

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_open_success(s.obj_pos, s.goal)
