"""Pick-place-wall: pick up a puck, carry it over a wall and hold it at a goal in the air (Meta-World
``pick-place-wall-v3``, MTBench ``task_fns/pick_place_wall.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState
from ._wall import MIDPOINT_Y, NEAR_OBJECT, TARGET_RADIUS, WALL_LINE_Y, two_stage_in_place

OBJ_Z = 0.02  # puck centre resting on the table


def pick_place_wall_midpoint(obj_init_pos: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench's midpoint: halfway between the initial puck and the goal laterally, just behind the wall line
    (y = 0.77) and at the goal's height ``[n, 3]``."""
    return torch.stack([0.5 * (obj_init_pos[:, 0] + goal[:, 0]), torch.full_like(goal[:, 1], MIDPOINT_Y),
                        goal[:, 2]], dim=-1)


def pick_place_wall_reward(action: torch.Tensor, obj: torch.Tensor, gripper_open: torch.Tensor, tcp: torch.Tensor,
                           left_pad: torch.Tensor, right_pad: torch.Tensor, goal: torch.Tensor,
                           obj_init_pos: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`PickPlaceWall`); points ``[n, 3]``, ``gripper_open`` ``[n]``, actions
    ``[n, 4]``."""
    part1, part2 = two_stage_in_place(obj, obj_init_pos, pick_place_wall_midpoint(obj_init_pos, goal), goal)
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    near = ((obj - tcp).norm(dim=-1) < NEAR_OBJECT) & (gripper_open > 0)
    past = near & (obj[:, 1] >= WALL_LINE_Y)
    return torch.where(past, grasp + 5.0 + 3.0 * part2, torch.where(near, grasp + 1.0 + 4.0 * part1, grasp))


def pick_place_wall_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class PickPlaceWall(FreeObjectTask):
    """Pick up the red puck (cylinder r 2 cm, h 4 cm, 0.75 kg) and bring it over Meta-World's wall (see ``_wall``)
    to the goal.

    * Reset (MTBench ranges mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``; equal to Meta-World
      pick-place-wall-v3's): puck x ~ U[-0.05, 0.05], y ~ U[0.6, 0.65]; goal x ~ U[-0.05, 0.05],
      y ~ U[0.85, 0.9], z ~ U[0.05, 0.3]; the puck rests at z = 0.02 (Meta-World's obj_low z = 0.015 sinks it
      5 mm into the table). Pairs closer than 15 cm in xy are resampled (Meta-World's loop; it cannot trigger
      with these ranges; MTBench has none).
    * Objects: the puck's pose (as Meta-World; MTBench also reported the wall's pose as object 2).
    * Dense reward (MTBench, before its ``× 0.01``): the staged reward of push_wall (see ``push_wall``) with a
      per-world midpoint ``((obj_init_x + goal_x) / 2, 0.77, goal_z)``. MTBench computed the midpoint of the
      whole task block from its first world (and took z from world 0 of the whole simulation); we use each
      world's own. Meta-World's reward is different (``hamacher(grasp, part1)``, a lifted condition, a midpoint
      at z = 0.25 and scaling of z).
    * Success: ``‖obj − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``).
    """

    name = "pick_place_wall"
    mtbench_id = 32
    description = "Pick up a puck, carry it over a wall and place it at the goal."
    scene = SceneSpec("sawyer_pick_place_wall_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # puck x, y, z then goal x, y, z
    reset_low = (-0.05, 0.6, OBJ_Z, -0.05, 0.85, 0.05)
    reset_high = (0.05, 0.65, OBJ_Z, 0.05, 0.9, 0.3)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return pick_place_wall_reward(action, s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad, s.goal,
                                      s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return pick_place_wall_success(s.obj_pos, s.goal)
