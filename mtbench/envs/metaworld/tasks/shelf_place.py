"""Shelf-place: pick up a block and put it on the middle board of a shelf (Meta-World ``shelf-place-v3``, MTBench
``task_fns/shelf_place.py``)."""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import (grasp_place_reward, gripper_caging_reward, hamacher_product, path_speed,
                            polyline_distance, tolerance)
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState, offset

OBJ_Z = 0.02  # block centre resting on the table
TARGET_RADIUS = 0.05
NEAR_OBJECT = 0.025
GOAL_ABOVE_SHELF = 0.3  # the shelf's goal site, above the shelf body origin
# MTBench's band in front of and below the goal, in its frame: z_mtb in [TABLE_Z, TABLE_Z + 0.3) with TABLE_Z =
# 1.027, i.e. z in [0, 0.3) here; its z_scaling divides by the absolute height TABLE_Z + 0.3 of its frame
BAND_TOP = 0.3
Z_SCALE_DENOM = 1.027 + 0.3
BAND_DEPTH = 3 * TARGET_RADIUS  # in front of the goal (MTBench x_mtb, our y)
BAND_HALF_WIDTH = 0.15  # laterally (MTBench y_mtb, our x)
# Collision geoms of Meta-World's shelf that MTBench's shelf asset removed (task_fns/README.md: "some shelf
# collisions were removed"): the bottom board, the back wall and the bottom block, given by their positions in the
# shelf frame. The side walls, the top and the middle board (which the block is placed on) collide.
REMOVED_SHELF_COLLISIONS = ((0.0, -0.015, 0.05), (0.0, 0.09, 0.32), (0.0, -0.008, 0.021))


def shelf_place_reward(action: torch.Tensor, obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                       left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                       init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`ShelfPlace`); points ``[n, 3]``, ``gripper_open`` ``[n]``, actions ``[n, 4]``."""
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    z_scaling = ((BAND_TOP - obj[:, 2]) / Z_SCALE_DENOM).clamp(0.0, 1.0)
    y_scaling = ((obj[:, 1] - (goal[:, 1] - BAND_DEPTH)) / BAND_DEPTH).clamp(0.0, 1.0)
    bound_loss = hamacher_product(y_scaling, z_scaling)
    in_band = ((obj[:, 2] >= 0.0) & (obj[:, 2] < BAND_TOP)
               & ((obj[:, 0] - goal[:, 0]).abs() < BAND_HALF_WIDTH))
    in_front = in_band & (obj[:, 1] > goal[:, 1] - BAND_DEPTH) & (obj[:, 1] < goal[:, 1])
    behind = in_band & (obj[:, 1] >= goal[:, 1])
    in_place = torch.where(in_front, (in_place - bound_loss).clamp(0.0, 1.0), in_place)
    in_place = torch.where(behind, 0.0, in_place)
    lifted = (((obj - tcp).norm(dim=-1) < NEAR_OBJECT) & (gripper_open > 0)
              & (obj[:, 2] - 0.01 > obj_init_pos[:, 2]))
    return torch.where(lifted, reward + 1.0 + 5.0 * in_place, reward)


V2_HOLD_RADIUS = 0.02  # v2: TCP within 2 cm of the block's centre (pick_place's value)
V2_FRONT = 0.16  # v2: the block waits this far in front of the goal (the board's front edge is 11 cm in front)
V2_BELOW = 0.03  # v2: a block more than this below the goal is below the board's top (goal: 5 cm above it)


def shelf_place_reward_v2(action: torch.Tensor, obj: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                          right_pad: torch.Tensor, gripper_open: torch.Tensor, goal: torch.Tensor,
                          obj_init_pos: torch.Tensor, init_tcp: torch.Tensor,
                          obj_vel: torch.Tensor | None = None) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..8): :func:`~..reward_utils.grasp_place_reward` (pick_place's
    form) with the block as grasp point and object, hold radius 2 cm, and the carry measured along the path up to a
    point 16 cm in front of the goal at the goal's height, then straight in, while the block is in front of the board or
    below its top; straight to the goal otherwise.

    Why: the paper-era reward takes from its long-tail ``in_place`` term in a band in front of the shelf up to
    the goal's height and pays 0 behind the goal, so carrying the block towards the shelf is punished on most of
    the way, and it pays the carry only in the hand and 1 cm up (0% for MT-PPO). The path here is the one that
    clears the board (the scripted policy's).
    Since ``v2-2026-11-28d`` (with ``obj_vel``, the block's velocity) the held block's speed towards its next waypoint
    is also paid (``progress_speed``): the MT50-rand policies held the object still one carry short of the goal
    (docs/results/mt50_rand_ppo.md, "Where the policy stops"). Since ``v2-2026-11-28f`` the path turns straight in
    at the front point itself (before: 3 cm past it, so that the path length *grew* by up to 3 cm over the first
    3 cm in, a dip in the reward just where the block has to go on).
    """
    front = torch.stack([goal[:, 0], goal[:, 1] - V2_FRONT, goal[:, 2]], dim=-1)
    outside = (obj[:, 1] < goal[:, 1] - V2_FRONT) | (obj[:, 2] < goal[:, 2] - V2_BELOW)
    stage = (~outside).long()
    carry = polyline_distance(obj, [front, goal], stage)
    carry0 = polyline_distance(obj_init_pos, [front, goal], torch.zeros_like(obj[:, 0], dtype=torch.long))
    speed = path_speed(obj_vel, obj, [front, goal], stage)
    return grasp_place_reward(action, tcp, left_pad, right_pad, gripper_open, obj, obj_init_pos, init_tcp,
                              obj[:, 2] - obj_init_pos[:, 2], carry, carry0,
                              obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
                              hold_radius=V2_HOLD_RADIUS, place_radius=TARGET_RADIUS, progress_speed=speed)


def shelf_place_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class ShelfPlace(FreeObjectTask):
    """Put the blue block (4 cm cube, 10 g, rotation-locked by its huge inertia) on the shelf's middle board.

    * Scene: Meta-World ``sawyer_shelf_placing.xml``; the shelf (a world-fixed body, moved per world with
      ``set_body_pos``) keeps the collision geoms MTBench kept: side walls, top and middle board (top face at
      shelf + 0.25); the bottom board, back wall and bottom block no longer collide (MTBench's README: "some shelf
      collisions were removed"; without the back wall the Panda hand, 10 cm long either side of the TCP along y,
      fits above the board with the TCP over the goal).
    * Reset (MTBench ranges mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): block
      x ~ U[-0.1, 0.1], y = 0.55 (MTBench's x_mtb = -0.05; Meta-World samples y in [0.5, 0.6]), z = 0.02; goal
      x ~ U[-0.1, 0.1], y ~ U[0.8, 0.9], z = 0.3 (Meta-World: the same, z in [0.299, 0.301]); the shelf at
      goal − (0, 0, 0.3), so the goal is the shelf's own goal site. Pairs closer than 10 cm in xy are resampled
      (Meta-World's loop; it cannot trigger with these ranges; MTBench has none).
    * Objects: the block's pose (as Meta-World; MTBench also reported the shelf's pose as object 2).
    * Dense reward (MTBench, before its ``× 0.01``)::

        in_place = tolerance(‖obj − goal‖, (0, .05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=.015, pad_success_thresh=.05, object_reach_radius=.01,
                               xz_thresh=.005, medium_density=True)
        r = hamacher(grasp, in_place)
        in the band 0 <= obj_z < 0.3, |obj_x − goal_x| < 0.15:
            goal_y − 0.15 < obj_y < goal_y:  in_place = clip(in_place − hamacher(y_scaling, z_scaling), 0, 1)
            obj_y >= goal_y:                 in_place = 0
        if ‖tcp − obj‖ < .025 and gripper_open > 0 and obj_z − .01 > obj_init_z:  r += 1 + 5·in_place

      with ``y_scaling = clip((obj_y − (goal_y − 0.15)) / 0.15, 0, 1)`` and ``z_scaling = clip((0.3 − obj_z) /
      1.327, 0, 1)`` (MTBench divides by the absolute height 1.027 + 0.3 of its frame; Meta-World's band is
      0 < z < 0.24, divided by 0.24, and it uses ``obj_radius=.02, xz_thresh=.01`` without medium density).
    * Success: ``‖obj − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``).
    * ``reward_version="v2"``: :func:`shelf_place_reward_v2` (pick_place's form, path in front of the
      shelf and in).
    """

    name = "shelf_place"
    mtbench_id = 42
    description = "Pick up a block and place it on a shelf."
    scene = SceneSpec("sawyer_shelf_placing.xml", hand_init_pos=(0.0, 0.5, 0.2))
    MIN_GOAL_DIST = 0.1  # Meta-World's shelf-place loop
    # block x, y, z then goal x, y, z
    reset_low = (-0.1, 0.55, OBJ_Z, -0.1, 0.8, 0.3)
    reset_high = (0.1, 0.55, OBJ_Z, 0.1, 0.9, 0.3)

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Drop the shelf collision geoms that MTBench's shelf asset does not have."""
        shelf = spec.body("shelf")
        geoms = [g for b in [shelf, *shelf.bodies] for g in b.geoms if g.contype or g.conaffinity]
        for pos in REMOVED_SHELF_COLLISIONS:
            match = [g for g in geoms if all(abs(a - b) < 1e-9 for a, b in zip(g.pos, pos))]
            if len(match) != 1:
                raise RuntimeError(f"shelf_place: expected one shelf collision geom at {pos}, found {len(match)}")
            match[0].contype, match[0].conaffinity = 0, 0

    def bind(self, model) -> None:
        super().bind(model)
        self.shelf_body = self.body_id("shelf")

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.place(s, vec[:, :3], vec[:, 3:6], mask)
        self.set_body_pos(s.sim, self.shelf_body, offset(vec[:, 3:6], 0.0, 0.0, -GOAL_ABOVE_SHELF), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return shelf_place_reward(action, s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad, s.goal,
                                  s.obj_init_pos, s.init_tcp)

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return shelf_place_reward_v2(action, s.obj_pos, s.tcp, s.left_pad, s.right_pad, s.gripper_open, s.goal,
                                     s.obj_init_pos, s.init_tcp, self.object_velocity(s))

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return shelf_place_success(s.obj_pos, s.goal)
