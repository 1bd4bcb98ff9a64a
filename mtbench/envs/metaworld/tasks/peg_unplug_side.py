"""Peg unplug side (MTBench ``peg_unplug_side``): the paper-era MTBench layout of Meta-World's
``peg-unplug-side-v3`` scene, in which the plug starts on the table in front of the outlet and has to be brought to
the outlet's hole."""

from __future__ import annotations

import math

import mujoco
import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..robot import FINGER_JOINTS
from ..scene import SceneSpec
from ..task import MetaWorldTask, Objects, TaskState, offset

TARGET_RADIUS = 0.05
BONUS_REACH = 0.02
GRIP_FROM_HEAD = (0.0, -0.06, 0.0)  # MTBench: grip point = observed peg head - (.06, 0, 0) in its frame
FINGER_TRAVEL = 0.08  # MTBench's tcp_opened = (q_finger1 + q_finger2) / 0.08
# MTBench's outlet ("plug_wall" actor) is turned by 180 degrees about z in its frame: -90 degrees in ours, so that
# the outlet's face (its +x side in the asset) looks at the robot (-y); Meta-World leaves it unturned (facing +x)
WALL_QUAT = (math.cos(-math.pi / 4), 0.0, 0.0, math.sin(-math.pi / 4))
# MTBench's plug ("plug" actor) is turned by 180 degrees about its frame's y axis: 180 degrees about -x after
# a +90 degree turn about z here (wxyz), so the plug lies along y with its head (pegHead) towards the outlet
PLUG_QUAT = (0.0, math.sqrt(0.5), -math.sqrt(0.5), 0.0)
PLUG_FROM_WALL = (0.0, -0.15, 0.0)  # MTBench: plug = wall + (-.15, 0, 0) in its frame
# MTBench drops the plug at table height; Meta-World's plug (larger than MTBench's) rests on its 4.5 cm flange
PLUG_REST_Z = 0.045
GOAL_FROM_WALL = (0.0, -0.02, 0.131)  # MTBench: target = wall + (-.02, 0, .131) in its frame (the outlet's hole)


def peg_unplug_side_reward(action: torch.Tensor, head: torch.Tensor, goal: torch.Tensor, head_init: torch.Tensor,
                           tcp: torch.Tensor, left_pad: torch.Tensor, right_pad: torch.Tensor,
                           init_tcp: torch.Tensor, finger_opening: torch.Tensor) -> torch.Tensor:
    """MTBench's ``peg_unplug_side`` dense term before its ``* .01`` (``[n]``, in [0, 7])::

        in_place = tol(‖head − goal‖, (0, .05), margin ‖head_init − goal‖, long_tail)
        grasp    = caging(head; obj_radius .02, pad_success_thresh .05, object_reach_radius 0, xz_thresh .005,
                          medium density)
        r = hamacher(grasp, in_place)
        r += 1 + 5·in_place  if ‖head + (0, −0.06, 0) − tcp‖ < .02 and finger_opening > 0
                               and head_z − .01 > head_init_z
    """
    in_place = tolerance((head - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=(head_init - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, head, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=head_init, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    tcp_to_grip = (offset(head, *GRIP_FROM_HEAD) - tcp).norm(dim=-1)
    lifted = head[:, 2] - 0.01 > head_init[:, 2]
    bonus = (tcp_to_grip < BONUS_REACH) & (finger_opening > 0) & lifted
    return torch.where(bonus, reward + 1.0 + 5.0 * in_place, reward)


def peg_unplug_side_success(head: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖head − goal‖ < 0.05`` (``[n]`` bool)."""
    return (head - goal).norm(dim=-1) < TARGET_RADIUS


class PegUnplugSide(MetaWorldTask):
    """MTBench's paper-era ``peg_unplug_side`` (Meta-World's ``sawyer_peg_unplug_side.xml`` objects).

    * What MTBench does (``task_fns/peg_unplug_side.py``, ed2e2b5): it does *not* start with the plug in the
      outlet. Its reset puts the outlet (``plug_wall``, fixed) at the sampled position, turned to face the robot,
      and drops the plug on the table 15 cm in front of it, lying along the robot's forward axis with its head
      towards the outlet; the target is the outlet's hole, 13.1 cm above the table, and the reward has a
      "grasped and lifted" bonus. In effect: pick the plug up and bring its head to the hole. This file reproduces
      that layout in our frame.
    * Scene and reset: outlet body ``box`` ~ U([-0.25, 0.8, 0], [-0.15, 0.9, 0]) (MTBench x_mtb in [.2, .3], y_mtb
      in [.15, .25] mapped; Meta-World samples y in [0.6, 0.8] and leaves the outlet facing +x), turned by -90
      degrees about z (``WALL_QUAT``, in ``edit_spec``). Plug (``plug1``, free) at outlet + (0, -0.15, 0.045), turned
      by ``PLUG_QUAT`` (its head, the ``pegHead`` site, 4 cm from its origin, points at the outlet). The 4.5 cm
      height is where Meta-World's plug rests on its flange (MTBench drops its smaller plug from table height).
      Goal = outlet + (0, -0.02, 0.131) (the hole). ``obj_init_pos`` = the ``pegHead`` site at reset (MTBench:
      outlet + (-.11, 0, .024) in its frame, its estimate of the same point).
    * Observation: object 1 = ``pegHead`` with the plug's orientation (MTBench's ``pegHead`` body); object 2 = the
      outlet body and orientation (MTBench's ``plug_wall`` root).
    * Dense reward: :func:`peg_unplug_side_reward` (``dense_scale`` 0.01); ``finger_opening`` is MTBench's
      ``(q_finger1 + q_finger2) / 0.08`` from the Panda's finger joints.
    * Success (MTBench): ``‖pegHead − goal‖ < 0.05``.
    * Physics note: the plug lies along y, the axis along which the fingers open, and is 16.5 cm long (Meta-World's
      plug; MTBench's 12.5 cm), so neither gripper can close across it and the task is not solvable by grasping;
      the scripted policy only pushes the plug against the outlet (0% success). The same holds for MTBench's
      Franka, whose fingers also open along the plug's axis.
    * Differences: the hand starts with its TCP at (0, 0.6, 0.2) (Meta-World's ``hand_init_pos``); ``init_tcp`` is
      recorded at every reset (MTBench: once per run).
    """

    name = "peg_unplug_side"
    mtbench_id = 29
    description = "Pull a peg sideways out of the hole it is plugged into."
    scene = SceneSpec("sawyer_peg_unplug_side.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # outlet position x, y, z (MTBench's reset space mapped; its goal part is unused)
    reset_low = (-0.25, 0.8, 0.0)
    reset_high = (-0.15, 0.9, 0.0)

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Turn the outlet to face the robot (MTBench's layout)."""
        wall = spec.body("box")
        if wall is None:
            raise ValueError("peg_unplug_side: no body 'box' in the scene")
        wall.quat = list(WALL_QUAT)

    def bind(self, model) -> None:
        body = model.body("plug1")
        self.plug_qpos = int(model.jnt_qposadr[int(body.jntadr[0])])
        self.plug_body = self.body_id("plug1")
        self.wall_body = self.body_id("box")
        self.head_site = self.site_id("pegHead")
        self.finger_qpos = tuple(self.joint_qposadr(n) for n in FINGER_JOINTS)
        self._plug_quat = self.const(PLUG_QUAT)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        wall = vec[:, :3]
        self.set_body_pos(s.sim, self.wall_body, wall, mask)
        plug = offset(wall, PLUG_FROM_WALL[0], PLUG_FROM_WALL[1], PLUG_REST_Z)
        self.set_free_body(s.sim, self.plug_qpos, plug, mask, self._plug_quat.expand(s.n, 4))
        self.masked_set(s.goal, offset(wall, *GOAL_FROM_WALL), mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        self.masked_set(s.obj_init_pos, s.obj_pos, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.site_xpos[:, self.head_site], s.sim.xquat[:, self.plug_body],
                       s.sim.xpos[:, self.wall_body], s.sim.xquat[:, self.wall_body])

    def finger_opening(self, s: TaskState) -> torch.Tensor:
        q = s.sim.qpos
        return (q[:, self.finger_qpos[0]] + q[:, self.finger_qpos[1]]) / FINGER_TRAVEL

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return peg_unplug_side_reward(action, s.obj_pos, s.goal, s.obj_init_pos, s.tcp, s.left_pad, s.right_pad,
                                      s.init_tcp, self.finger_opening(s))

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return peg_unplug_side_success(s.obj_pos, s.goal)
