"""Door open: swing a hinged safe door open by its handle (Meta-World ``door-open-v3``).

Scene: Meta-World's ``sawyer_door_pull.xml`` (``doorlockB``). The safe (body ``door``) is a fixed body whose
position is sampled per world (batched ``body_pos``); the door panel (``door_link``) turns about a vertical hinge
(``doorjoint``, range [-2, 0] rad, closed at 0, opening towards the robot). The handle is a horizontal bar
sticking out of the panel's outer face. All of the door's collision geoms have ``contype = conaffinity = 1``, so
the Panda (contype 1) collides with the handle, the panel and the safe.

Observation (object part): position and quaternion (wxyz) of the ``handle`` geom (Meta-World's
``_get_pos_objects`` / ``_get_quat_objects``; the geom frame is the mesh's centre after MuJoCo re-centres it,
at (0.191, -0.207, 0) from the safe's origin when closed). Goal: ``door + (-0.3, -0.45, 0)``.

Reward: Meta-World v2 ``compute_reward`` (metaworld 3.0.0, without the success override), Meta-World's scale::

    door           = handle + (-0.05, 0, 0)
    above_floor    = above_floor_funnel(hand, door, threshold=0.12)        # log funnel around the handle
    in_place       = tolerance(|hand - door - (0.05, 0.03, -0.01)|, (0, 0.06), margin=0.5, long_tail)
    ready_to_open  = hamacher(above_floor, in_place)
    opened         = 0.2 * [theta < -pi/90] + 0.8 * tolerance(pi/2 + pi/6 + theta, (0, 0.5), margin=pi/3, long_tail)
    grab           = (clip(action[3], -1, 1) + 1) / 2
    r = 2 * hamacher(ready_to_open, grab) + 8 * opened

with ``theta`` the hinge angle (negative = open) and ``hand`` = ``obs[0:3]``.

Success (paper-era MTBench ``|door_y - target_y| <= 0.08`` in MTBench's frame, whose y axis is Meta-World's -x
and whose "door" is the handle body): in Meta-World's frame ``|handle_x - goal_x| <= 0.08``, which is also
Meta-World's own rule. With the handle geometry this holds for hinge angles in about [-1.82, -1.38] rad
(door opened 79 to 104 degrees).

Physics notes: the opening panel meets the safe's side wall at about -1.53 rad, inside the success band. The
Panda's palm is 20 cm long along the finger axis (world y), so it cannot put its closed fingers between the bar and
the panel as the Sawyer does; it can straddle the bar with open fingers (the scripted policy pulls with the far
finger, then pushes the panel's inner face). The ``in_place`` ball (6 cm) is reachable in that pose, but the grab
term pays for closing the fingers, which there grasps the bar, and the weld holds the hand orientation while the
bar turns, so a closed grasp resists opening; an agent has to trade the 2 grab points for the 8 opening points.

Differences to Meta-World: ``hand`` is the Panda's finger-pad midpoint (the framework's ``obs[0:3]``; Meta-World
used the Sawyer hand body). MTBench replaced the grab-effort term by the gripper openness and moved the funnel and
the in-place target for the Franka; this task keeps Meta-World's v2 reward (not the 2026 upstream change).
The safe's own collision geoms move with it (``WarpSim.set_body_pos``; MuJoCo Warp treats them as static).
"""

from __future__ import annotations

import math

import mujoco
import torch

from ..reward_utils import above_floor_funnel, hamacher_product, tolerance
from ..scene import SceneSpec, guide_by_joint
from ..task import MetaWorldTask, Objects, TaskState, offset


def quat_mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product of wxyz quaternions (broadcasting over leading dims)."""
    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], dim=-1)


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate vectors ``v`` by wxyz unit quaternions ``q``."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * torch.linalg.cross(u, v)
    return v + w * t + torch.linalg.cross(u, t)


def door_open_reward(hand: torch.Tensor, handle: torch.Tensor, theta: torch.Tensor,
                     grab_action: torch.Tensor) -> torch.Tensor:
    """Meta-World v2 dense reward of door-open (``[n]``, scale 0..10); pure function of tensors."""
    door = offset(handle, -0.05, 0.0, 0.0)
    threshold = DoorOpen.FUNNEL_THRESHOLD
    above_floor = above_floor_funnel(hand, door, threshold)
    in_place = tolerance(
        offset(hand - door, -0.05, -0.03, 0.01).norm(dim=-1),
        bounds=(0.0, threshold / 2.0), margin=0.5, sigmoid="long_tail",
    )
    ready_to_open = hamacher_product(above_floor, in_place)
    opened = 0.2 * (theta < -math.pi / 90.0).to(hand.dtype) + 0.8 * tolerance(
        math.pi / 2.0 + math.pi / 6.0 + theta, bounds=(0.0, 0.5), margin=math.pi / 3.0, sigmoid="long_tail",
    )
    grab = (grab_action.clamp(-1.0, 1.0) + 1.0) / 2.0
    return 2.0 * hamacher_product(ready_to_open, grab) + 8.0 * opened


def door_open_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``|handle_x - goal_x| <= 0.08`` (MTBench's rule expressed in Meta-World's frame; ``[n]`` bool)."""
    return (handle[..., 0] - goal[..., 0]).abs() <= DoorOpen.SUCCESS_TOL


class DoorOpen(MetaWorldTask):
    """Swing the safe door open by about 90 degrees (see the module docstring)."""

    name = "door_open"
    mtbench_id = 16
    description = "Grab the door handle and swing the door open on its hinges."
    scene = SceneSpec("sawyer_door_pull.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # safe (door body) position x, y, z (Meta-World obj_low/obj_high); the goal follows from it
    reset_low = (0.0, 0.85, 0.15)
    reset_high = (0.1, 0.95, 0.15)
    GOAL_OFFSET = (-0.3, -0.45, 0.0)
    FUNNEL_THRESHOLD = 0.12
    SUCCESS_TOL = 0.08

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """The door turns on its hinge alone (no contacts with its frame or the wall; stiff limit)."""
        guide_by_joint(spec, "door_link", "doorjoint", ("doorlockB", "RetainingWall"))

    def bind(self, model) -> None:
        self.door_body = self.body_id("door")
        self.link_body = self.body_id("door_link")
        self.door_qpos = self.joint_qposadr("doorjoint")
        handle = model.geom("handle")
        if int(handle.bodyid[0]) != self.link_body:
            raise RuntimeError("door handle geom is expected on body door_link")
        # handle geom frame relative to door_link (after MuJoCo's mesh re-centring)
        self._handle_local = self.const([*handle.pos, *handle.quat])

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.set_body_pos(s.sim, self.door_body, vec[:, :3], mask)
        self.set_joint(s.sim, self.door_qpos, 0.0, mask)
        self.masked_set(s.obj_init_pos, vec[:, :3], mask)
        self.masked_set(s.goal, offset(vec[:, :3], *self.GOAL_OFFSET), mask)

    def handle_pose(self, s: TaskState) -> tuple[torch.Tensor, torch.Tensor]:
        """World position and wxyz quaternion of the handle geom ``[n, 3], [n, 4]``."""
        link_pos = s.sim.xpos[:, self.link_body]
        link_quat = s.sim.xquat[:, self.link_body]
        local = self._handle_local
        pos = link_pos + quat_rotate(link_quat, local[:3].expand_as(link_pos))
        quat = quat_mul(link_quat, local[3:].expand_as(link_quat))
        return pos, quat

    def objects(self, s: TaskState) -> Objects:
        return Objects(*self.handle_pose(s))

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_open_reward(s.tcp, s.obj_pos, s.sim.qpos[:, self.door_qpos], action[:, 3])

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_open_success(s.obj_pos, s.goal)
