"""Coffee pull: pull a mug from in front of the coffee machine to a goal nearer the robot (Meta-World
``coffee-pull-v3``, MTBench id 9)."""

from __future__ import annotations

import torch

from ..reward_utils import (
    gripper_caging_reward,
    hamacher_product,
    mtbench_gripper_openness,
    scaled_norm,
    tolerance,
)
from ..task import MetaWorldTask, Objects, TaskState
from ._coffee import SCENE, CoffeeSceneMixin, edit_coffee_scene, place_mug_task

IN_PLACE_SCALE = (2.0, 2.0, 1.0)  # MTBench's specialized_kwargs["scale"] (x and y scaled alike: same in our frame)
TARGET_RADIUS = 0.05
TCP_RADIUS = 0.04  # MTBench: the "hand at the mug" radius of the bonus and of the success rule


def coffee_pull_reward(action: torch.Tensor, obj: torch.Tensor, obj_init: torch.Tensor, goal: torch.Tensor,
                       tcp: torch.Tensor, init_tcp: torch.Tensor, left_pad: torch.Tensor, right_pad: torch.Tensor
                       ) -> torch.Tensor:
    """MTBench ``coffee_pull`` dense term before its ``* .01`` (``[n]``)::

        in_place = tol(‖(obj − goal)·(2, 2, 1)‖, (0, .05), margin ‖(obj_init − goal)·(2, 2, 1)‖, long_tail)
        grasped  = gripper_caging(obj_radius=.02, pad_success_thresh=.05, object_reach_radius=.04, xz_thresh=.05,
                                  desired_gripper_effort=.7, medium_density=True)
        r = H(grasped, in_place) + (1 + 5·in_place  if ‖obj − tcp‖ < .04 and openness > 0)
    """
    in_place = tolerance(scaled_norm(obj - goal, IN_PLACE_SCALE), bounds=(0.0, TARGET_RADIUS),
                         margin=scaled_norm(obj_init - goal, IN_PLACE_SCALE), sigmoid="long_tail")
    grasped = gripper_caging_reward(
        action, obj, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.04, xz_thresh=0.05,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init, init_tcp=init_tcp,
        desired_gripper_effort=0.7, medium_density=True,
    )
    reward = hamacher_product(grasped, in_place)
    near = ((obj - tcp).norm(dim=-1) < TCP_RADIUS) & (mtbench_gripper_openness(left_pad, right_pad) > 0)
    return torch.where(near, reward + 1.0 + 5.0 * in_place, reward)


def coffee_pull_success(obj: torch.Tensor, goal: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                        right_pad: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖obj − goal‖ <= 0.05`` and ``‖obj − tcp‖ < 0.04`` and the gripper not fully closed."""
    near = ((obj - tcp).norm(dim=-1) < TCP_RADIUS) & (mtbench_gripper_openness(left_pad, right_pad) > 0)
    return ((obj - goal).norm(dim=-1) <= TARGET_RADIUS) & near


class CoffeePull(CoffeeSceneMixin, MetaWorldTask):
    """Pull the mug towards the robot onto the goal and keep the hand at it.

    * Scene: Meta-World ``sawyer_coffee.xml`` (hand starts at Meta-World's (0, 0.4, 0.2)).
    * Reset (MTBench, mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): mug at x ~ U[-0.05, 0.05],
      y ~ U[0.65, 0.70] on the table (MTBench ``(.05, -.05) .. (.10, .05)``, "modified in x from metaworld so
      machine doesn't hang over edge"; Meta-World v3: y in [0.7, 0.75]); goal x ~ U[-0.1, 0.1], y ~ U[0.5, 0.6],
      z = 0 (MTBench ``(-.1, -.1) .. (0, .1)`` at the table surface; Meta-World v3: y in [0.55, 0.65]). No
      resampling of close pairs (MTBench has none; the ranges are 5 cm apart in y). The machine stands 0.3 behind
      the mug (MTBench; Meta-World: 0.22, the mug under the spout), its button released; the mug's handle points
      to -x as MTBench spawns it.
    * Observation: object 1 = MTBench's mug point, the centre of its collision cylinder (3.5 cm above the table at
      rest), and its quaternion; object 2 = ``buttonStart`` and the button's quaternion (MTBench reports both).
      ``obj_init_pos`` = the sampled mug position at table height (MTBench: its mug actor's spawn point, whose
      origin is the cylinder's centre, spawned at table height before it settles).
    * Dense reward: :func:`coffee_pull_reward` (MTBench before ``* .01``; ``a[3] = +1`` closes, as the caging
      term's "gripper closed" expects).
    * Success: ``‖obj − goal‖ <= 0.05``, ``‖obj − tcp‖ < 0.04``, openness > 0 (MTBench); success steps pay 10.
      As in MTBench the goal lies on the table while the observed mug point is 3.5 cm above it, so the mug must be
      within about 3.6 cm of the goal in x-y.
    * Differences: ``init_tcp`` per reset (MTBench: once); Meta-World's ``tolerance`` inside the bounds (MTBench's
      returns 0 there when the margin is positive).
    """

    name = "coffee_pull"
    mtbench_id = 9
    description = "Pull a coffee mug away from underneath the coffee machine to a goal position."
    scene = SCENE
    reset_low = (-0.05, 0.65, 0.0, -0.1, 0.5, 0.0)
    reset_high = (0.05, 0.70, 0.0, 0.1, 0.6, 0.0)

    @classmethod
    def edit_spec(cls, spec) -> None:
        edit_coffee_scene(spec)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        place_mug_task(self, s, vec, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(*self.mug_pose(s), *self.button_pose(s))

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return coffee_pull_reward(action, s.obj_pos, s.obj_init_pos, s.goal, s.tcp, s.init_tcp, s.left_pad,
                                  s.right_pad)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return coffee_pull_success(s.obj_pos, s.goal, s.tcp, s.left_pad, s.right_pad)
