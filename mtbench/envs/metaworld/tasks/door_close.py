"""Door close: push the open safe door shut (Meta-World ``door-close-v3``, MTBench id 13)."""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import reach_progress_reward, tolerance
from ..scene import SceneSpec
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._door import DOOR_BODY, DOOR_JOINT, HANDLE_SITE, SAFE_BODY, edit_door_scene
OPEN_ANGLE = -1.5708  # MTBench and Meta-World start the door opened by 90 degrees
GOAL_FROM_SAFE = (0.15, -0.16, 0.0)  # MTBench: root + (-.16, -.15, 0) in its frame ("metaworld uses -.2,-.2")
TARGET_RADIUS = 0.05


def door_close_reward(tcp: torch.Tensor, obj: torch.Tensor, obj_init: torch.Tensor, goal: torch.Tensor,
                      init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench ``door_close`` dense term before its ``* .01`` (``[n]``)::

        in_place      = tol(‖obj − goal‖, (0, .05), margin ‖obj − obj_init‖, gaussian)
        hand_in_place = tol(‖tcp − goal‖, (0, .0125), margin ‖init_tcp − obj‖, gaussian)
        r = 3 · hand_in_place + 6 · in_place

    Both margins use the *current* handle point as MTBench does (the first is 0 at the start: ``in_place`` is then
    binary, 1 only inside the 5 cm ball).
    """
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS), margin=(obj - obj_init).norm(dim=-1),
                         sigmoid="gaussian")
    hand_in_place = tolerance((tcp - goal).norm(dim=-1), bounds=(0.0, 0.25 * TARGET_RADIUS),
                              margin=(init_tcp - obj).norm(dim=-1), sigmoid="gaussian")
    return 3.0 * hand_in_place + 6.0 * in_place


V2_REACH_RADIUS = 0.05  # v2: TCP within 5 cm of the handle point counts as at the handle


def door_close_reward_v2(tcp: torch.Tensor, obj: torch.Tensor, obj_start: torch.Tensor, goal: torch.Tensor,
                         init_tcp: torch.Tensor) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..8)::

        reach = tolerance(‖tcp − obj‖, (0, .05), margin=‖init_tcp − obj_start‖ − .05, long_tail)
        close = progress(‖obj − goal‖, ‖obj_start − goal‖, .05)   # linear in the handle's distance to the goal
        r = 2·max(reach, close) + 6·close

    Why: the paper-era reward pays nothing before the door moves (its ``in_place`` has a zero margin at the start
    and its hand term is a Gaussian around the goal, 0.72 m from the hand's start): along the scripted controller's
    successful path the mean reward per step is 0.00 over the first 30 steps, random actions earn 0.004 per
    episode, and one of three MT50-rand runs never found the door (docs/results/mt50_rand_ppo.md). Here reaching the
    handle (0.3 m from the hand's start, on the hand's side of the open door) pays up to 2 on its own, and each
    centimetre that the handle travels towards the goal pays the same; ``max(reach, close)`` keeps the reach term
    while the door closes, so pushing it shut from anywhere on its face costs nothing
    (:func:`~..reward_utils.reach_progress_reward`, dial_turn's v2 form).
    """
    return reach_progress_reward((tcp - obj).norm(dim=-1), (init_tcp - obj_start).norm(dim=-1), V2_REACH_RADIUS,
                                 (obj - goal).norm(dim=-1), (obj_start - goal).norm(dim=-1), TARGET_RADIUS)


def door_close_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖obj − goal‖ < 0.05`` (the door within about 0.14 rad of closed; ``[n]`` bool)."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class DoorClose(MetaWorldTask):
    """Swing the safe's open door (90 degrees) shut.

    * Scene: Meta-World ``sawyer_door_pull.xml`` (``doorlockB``): the safe (body ``door``, world-fixed, placed per
      world) and its door (``door_link``) on the vertical hinge ``doorjoint`` (range [-2, 0] rad, closed at 0,
      opening towards the robot) at ``safe + (-0.185, -0.1, 0)``; the door turns on its hinge alone (no contacts
      with the safe or the retaining wall, stiff limit), as door_open's. Hand starts at Meta-World's
      (-0.5, 0.6, 0.2), beside the open door on its handle side (MTBench also starts this task with the arm turned
      aside so that it does not intersect the door).
    * Reset (MTBench ``obj_low/obj_high`` (.35, -.1) .. (.45, 0) at table + .3/2, mapped ``x = -y_mtb``,
      ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): safe at x ~ U[0, 0.1], y ~ U[0.95, 1.05], z = 0.15; door at
      -1.5708. Meta-World v3 samples y in [0.85, 0.95]: MTBench moved the safe 10 cm back (its back then overhangs
      Meta-World's table edge and retaining wall, static bodies that do not collide with it).
    * Observation: object 1 = MTBench's ``handle`` body, ``door_link + (0.325, -0.062, 0)`` in the door's frame
      (site ``handle_point``; Meta-World observes the handle mesh's centre instead), and the door's quaternion.
      ``obj_init_pos`` = that point at reset (MTBench hard-codes it as ``root + (-.425, .25, 0)``, i.e.
      ``safe + (-0.25, -0.425, 0)`` here; the measured point is ``safe + (-0.247, -0.425, 0)``). Goal =
      ``safe + (0.15, -0.16, 0)``, 1 cm from the closed handle point (``safe + (0.14, -0.162, 0)``).
    * Dense reward: :func:`door_close_reward` (MTBench before ``* .01``); ``reward_version="v2"``:
      :func:`door_close_reward_v2` (reach the handle, then linear pay for the handle's way to the goal).
    * Success: ``‖obj − goal‖ < 0.05``; success steps pay 10.
    * Differences: ``init_tcp`` per reset (MTBench: once); Meta-World's ``tolerance`` inside the bounds (MTBench's
      returns 0 there when the margin is positive, and 0 everywhere for a zero margin: its ``in_place`` was 0
      until the door moved).
    """

    name = "door_close"
    mtbench_id = 13
    description = "Push an open door shut by swinging it on its hinges."
    scene = SceneSpec("sawyer_door_pull.xml", hand_init_pos=(-0.5, 0.6, 0.2))
    reset_low = (0.0, 0.95, 0.15)
    reset_high = (0.1, 1.05, 0.15)

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """The door turns on its hinge alone; the site ``handle_point`` marks MTBench's handle point."""
        edit_door_scene(spec)

    def bind(self, model) -> None:
        self.safe_body = self.body_id(SAFE_BODY)
        self.door_body = self.body_id(DOOR_BODY)
        self.door_qpos = self.joint_qposadr(DOOR_JOINT)
        self.handle_site = self.site_id(HANDLE_SITE)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        safe = vec[:, :3]
        self.set_body_pos(s.sim, self.safe_body, safe, mask)
        self.set_joint(s.sim, self.door_qpos, OPEN_ANGLE, mask)
        self.masked_set(s.goal, offset(safe, *GOAL_FROM_SAFE), mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        self.masked_set(s.obj_init_pos, s.obj_pos, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.site_xpos[:, self.handle_site], s.sim.xquat[:, self.door_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_close_reward(s.tcp, s.obj_pos, s.obj_init_pos, s.goal, s.init_tcp)

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_close_reward_v2(s.tcp, s.obj_pos, s.obj_init_pos, s.goal, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_close_success(s.obj_pos, s.goal)
