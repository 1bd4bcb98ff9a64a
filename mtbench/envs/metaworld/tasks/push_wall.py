"""Push-wall: move a puck around a wall to a goal on the table behind it (Meta-World ``push-wall-v3``, MTBench
``task_fns/push_wall.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import grasp_place_reward, gripper_caging_reward, path_speed, polyline_distance, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState
from ._wall import MIDPOINT_Y, V2_BEHIND_Y, V2_HOLD_RADIUS, V2_LIFT_Y, scaled_norm, wall_stage

OBJ_Z = 0.02  # puck centre resting on the table
TARGET_RADIUS = 0.05
NEAR_OBJECT = 0.03
PAST_WALL_Y = 0.75  # MTBench: obj_x_mtb >= 0.15, the wall's centre line
# MTBench's midpoint (0.17, 0.1, 1.047) in its frame: beside the wall's left end (x -0.02), just behind it
MIDPOINT = (-0.1, MIDPOINT_Y, 0.02)


def push_wall_reward(action: torch.Tensor, obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                     left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                     init_tcp: torch.Tensor, midpoint: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`PushWall`); points ``[n, 3]``, ``gripper_open`` ``[n]``, actions ``[n, 4]``."""
    part1 = tolerance(scaled_norm(obj - midpoint), bounds=(0.0, TARGET_RADIUS),
                      margin=scaled_norm(obj_init_pos - midpoint), sigmoid="long_tail")
    part2 = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                      margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    near = ((obj - tcp).norm(dim=-1) < NEAR_OBJECT) & (gripper_open > 0)
    past = near & (obj[:, 1] >= PAST_WALL_Y)
    return torch.where(past, grasp + 5.0 + 3.0 * part2, torch.where(near, grasp + 1.0 + 4.0 * part1, grasp))


V2_LANE_X = -0.07  # v2: puck x while passing the wall's left end (-0.02) with the hand (2.5 cm half width) beside it
V2_IN_LANE = V2_LANE_X + 0.015
V2_CARRY_Z = 0.03  # v2: puck centre 1 cm above the table while carried


def push_wall_reward_v2(action: torch.Tensor, obj: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                        right_pad: torch.Tensor, gripper_open: torch.Tensor, goal: torch.Tensor,
                        obj_init_pos: torch.Tensor, init_tcp: torch.Tensor,
                        obj_vel: torch.Tensor | None = None) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..8): :func:`~..reward_utils.grasp_place_reward` (pick_place's
    form) with the puck as grasp point and object, hold radius 2.5 cm, and the carry measured along the path around the
    wall's left end: sideways in front of the wall (y = 0.625) into the lane x = -0.07, along the lane to behind the
    wall (y = 0.87), then to the goal, from the puck's current waypoint on (0 outside the lane in front of the wall, 1
    in the lane, 2 past the wall: :func:`._wall.wall_stage`).

    Why: the paper-era reward pays reaching through the caging term (at most ~0.5), and the way around the wall
    through a long-tail term towards a point behind the wall's end with the forward distance counted three times,
    which pays for pushing the puck straight into the wall; MT-PPO stays at 0%. v2 pays the grasp (caging) and,
    with the puck held and 1 cm up, the way along a path that clears the wall with the hand.
    Since ``v2-2026-11-28d`` (with ``obj_vel``, the puck's velocity) the held puck's speed towards its next waypoint
    is also paid (``progress_speed``): the MT50-rand policies held the object still one carry short of the goal
    (docs/results/mt50_rand_ppo.md, "Where the policy stops").
    """
    z = torch.full_like(obj[:, 2], V2_CARRY_Z)
    lane_front = torch.stack([torch.full_like(z, V2_LANE_X), obj_init_pos[:, 1].clamp_max(V2_LIFT_Y), z], dim=-1)
    lane_back = torch.stack([torch.full_like(z, V2_LANE_X), torch.full_like(z, V2_BEHIND_Y), z], dim=-1)
    points = [lane_front, lane_back, goal]
    stage = wall_stage(obj, obj[:, 0] <= V2_IN_LANE)
    carry = polyline_distance(obj, points, stage)
    carry0 = polyline_distance(obj_init_pos, points, torch.zeros_like(obj[:, 0], dtype=torch.long))
    speed = path_speed(obj_vel, obj, points, stage)
    return grasp_place_reward(action, tcp, left_pad, right_pad, gripper_open, obj, obj_init_pos, init_tcp,
                              obj[:, 2] - obj_init_pos[:, 2], carry, carry0,
                              obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
                              hold_radius=V2_HOLD_RADIUS, place_radius=TARGET_RADIUS, progress_speed=speed)


def push_wall_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class PushWall(FreeObjectTask):
    """Move the red puck (cylinder r 2 cm, h 4 cm, 0.75 kg) past Meta-World's wall (see ``_wall``) to the goal.

    * Reset (MTBench ranges mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``; equal to Meta-World
      push-wall-v3's): puck x ~ U[-0.05, 0.05], y ~ U[0.6, 0.65], goal x ~ U[-0.05, 0.05], y ~ U[0.85, 0.9], both
      at z = 0.02 (MTBench: table + 2 cm; Meta-World's goal takes the puck's height). Pairs closer than 15 cm in
      xy are resampled (Meta-World's loop; it cannot trigger with these ranges; MTBench has none).
    * Objects: the puck's pose (as Meta-World; MTBench also reported the wall's pose as object 2).
    * Dense reward (MTBench, before its ``× 0.01``)::

        part1 = tolerance(‖(obj − mid)·(1, 3, 1)‖, (0, .05), margin=‖(obj_init − mid)·(1, 3, 1)‖, long_tail)
        part2 = tolerance(‖obj − goal‖, (0, .05), margin=‖obj_init − goal‖, long_tail)
        grasp = gripper_caging(obj_radius=.015, pad_success_thresh=.05, object_reach_radius=.01,
                               xz_thresh=.005, medium_density=True)
        r = grasp;  if ‖tcp − obj‖ < .03 and gripper_open > 0:  r = grasp + 1 + 4·part1,
                    and if also obj_y >= 0.75:                  r = grasp + 5 + 3·part2

      with MTBench's fixed midpoint ``mid = (-0.1, 0.77, 0.02)`` (MTBench (0.17, 0.1, 1.047)) and its scaling
      (3, 1, 1) of its x axis, our y (Meta-World: mid = (-0.05, 0.77, obj_z), scaling of x, and
      ``hamacher(grasp, part1)`` with high-density caging).
    * Success: ``‖obj − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``).
    * ``reward_version="v2"``: :func:`push_wall_reward_v2` (pick_place's form, path around the wall's end).
    """

    name = "push_wall"
    mtbench_id = 39
    description = "Push a puck around a wall to a goal position behind it."
    scene = SceneSpec("sawyer_push_wall_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # puck x, y, z then goal x, y, z
    reset_low = (-0.05, 0.6, OBJ_Z, -0.05, 0.85, OBJ_Z)
    reset_high = (0.05, 0.65, OBJ_Z, 0.05, 0.9, OBJ_Z)

    def bind(self, model) -> None:
        super().bind(model)
        self.midpoint = self.const(MIDPOINT)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return push_wall_reward(action, s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad, s.goal,
                                s.obj_init_pos, s.init_tcp, self.midpoint.expand_as(s.obj_pos))

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return push_wall_reward_v2(action, s.obj_pos, s.tcp, s.left_pad, s.right_pad, s.gripper_open, s.goal,
                                   s.obj_init_pos, s.init_tcp, self.object_velocity(s))

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return push_wall_success(s.obj_pos, s.goal)
