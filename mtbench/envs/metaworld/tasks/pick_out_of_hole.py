"""Pick-out-of-hole: grasp a small cylinder standing at the bottom of a hole in the table and lift it to a goal
in the air (Meta-World ``pick-out-of-hole-v3``, MTBench ``task_fns/pick_out_of_hole.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, MetaWorldTask, TaskState

OBJ_Z = 0.02  # cylinder centre resting on the floor of the hole (z = 0)
TARGET_RADIUS = 0.05  # success
IN_PLACE_RADIUS = 0.02
NEAR_OBJECT = 0.04
LIFT = 0.02
# MTBench: "pinched without object" when its openness |tips| / 0.095 < 0.33, i.e. the fingertips closer than 3.135 cm
PINCHED_BELOW = 0.33 * 0.095
# MTBench's above-floor funnel: flat within 3 cm of the initial object (x, y), log-shaped outside, around its
# TABLE_Z = 1.0325, which is 3.25 cm above the floor of its hole (its hole table's top at 1.0, rim 5.4 cm higher)
FUNNEL_RADIUS = 0.03
FUNNEL_SCALE = 0.015
FUNNEL_HEIGHT = 0.0325


def above_floor(tcp: torch.Tensor, obj_init_pos: torch.Tensor) -> torch.Tensor:
    """MTBench's ``above_floor`` ``[n]``: 1 where the TCP is above the funnel ``floor = 0.0325`` within 3 cm (xy) of
    the initial object, ``0.015·ln(r − 0.03 + 1e-6) + 0.0325`` beyond; below it ``tolerance(floor − z, (0, .01),
    margin=.02, long_tail)``."""
    radius = (tcp[:, :2] - obj_init_pos[:, :2]).norm(dim=-1)
    outside = radius > FUNNEL_RADIUS
    shifted = torch.where(outside, radius - FUNNEL_RADIUS, 1.0)  # keeps log() finite in the masked branch
    floor = torch.where(outside, FUNNEL_SCALE * torch.log(shifted + 1e-6) + FUNNEL_HEIGHT, FUNNEL_HEIGHT)
    below = tolerance((floor - tcp[:, 2]).clamp_min(0.0), bounds=(0.0, 0.01), margin=0.02, sigmoid="long_tail")
    return torch.where(tcp[:, 2] > floor, 1.0, below)


def pick_out_of_hole_reward(action: torch.Tensor, obj: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                            right_pad: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor,
                            init_tcp: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`PickOutOfHole`); points ``[n, 3]``, actions ``[n, 4]``."""
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init_pos, init_tcp=init_tcp,
        medium_density=True,
    )
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, IN_PLACE_RADIUS),
                         margin=(obj_init_pos - goal).norm(dim=-1), sigmoid="long_tail")
    reward = hamacher_product(grasp, in_place)
    near = (obj - tcp).norm(dim=-1) < NEAR_OBJECT
    pinched = (right_pad - left_pad).norm(dim=-1) < PINCHED_BELOW
    lifted = obj[:, 2] - LIFT > obj_init_pos[:, 2]
    held = near & lifted & ~pinched
    return torch.where(held, reward + 1.0 + 5.0 * hamacher_product(in_place, above_floor(tcp, obj_init_pos)), reward)


def pick_out_of_hole_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖obj − goal‖ < 0.05``."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class PickOutOfHole(FreeObjectTask):
    """Lift the red cylinder (r 2 cm, h 4 cm, 10 g, rotation-locked) out of the 30 × 30 cm, 5.4 cm deep hole.

    Heights: MTBench's hole table has its floor at z_mtb = 1.0 (not at its usual table top 1.027) and a 5.4 cm
    rim, Meta-World's has the floor at z = 0 and the same rim; this task maps ``z = z_mtb - 1.0`` (the floor to
    the floor; ``x = -y_mtb``, ``y = x_mtb + 0.6`` as everywhere).

    * Reset: the cylinder stands in the hole at (0, 0.75, 0.02) (MTBench drops it from 1.25 cm higher; Meta-World
      the same point); goal x ~ U[-0.1, 0.1], y ~ U[0.6, 0.7], z ~ U[0.1825, 0.3325] (MTBench: "changed -.1 -> 0"
      and "0 -> 0.1" for the Franka, i.e. 10 cm further from the robot than Meta-World's y in [0.5, 0.6]; its
      table-top estimate 1.0325 + [0.15, 0.3]). No goal is resampled: MTBench does not, and Meta-World's 15 cm
      rejection would throw away most of MTBench's goal range.
    * Objects: the cylinder's pose.
    * Dense reward (MTBench, before its ``× 0.01``)::

        grasp = gripper_caging(obj_radius=.02, pad_success_thresh=.05, object_reach_radius=0,
                               xz_thresh=.005, medium_density=True)
        in_place = tolerance(‖obj − goal‖, (0, .02), margin=‖obj_init − goal‖, long_tail)
        r = hamacher(grasp, in_place)
        if ‖tcp − obj‖ < .04 and obj_z − .02 > obj_init_z and not pinched:  r += 1 + 5·hamacher(in_place, above_floor)

      ``pinched``: pad distance below 3.135 cm (MTBench: openness ``|tips| / 0.095 < 0.33``); ``above_floor``: see
      :func:`above_floor` (MTBench's funnel sits at its table-top estimate, 3.25 cm above the floor, without
      Meta-World's +0.15 offset). Meta-World uses other caging parameters (``obj_radius=.015,
      pad_success_thresh=.02, xz_thresh=.03``, effort 0.1, high density).
    * Success: ``‖obj − goal‖ < 0.05`` (MTBench; Meta-World ``≤ 0.07``).
    """

    name = "pick_out_of_hole"
    mtbench_id = 30
    description = "Pick a small object up out of a hole in the table and lift it to a goal."
    scene = SceneSpec("sawyer_pick_out_of_hole.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # cylinder x, y, z then goal x, y, z
    reset_low = (0.0, 0.75, OBJ_Z, -0.1, 0.6, 0.1825)
    reset_high = (0.0, 0.75, OBJ_Z, 0.1, 0.7, 0.3325)

    def sample(self, n: int, generator: torch.Generator, device: torch.device) -> torch.Tensor:
        return MetaWorldTask.sample(self, n, generator, device)  # MTBench: no resampling of close pairs

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return pick_out_of_hole_reward(action, s.obj_pos, s.tcp, s.left_pad, s.right_pad, s.goal, s.obj_init_pos,
                                       s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return pick_out_of_hole_success(s.obj_pos, s.goal)
