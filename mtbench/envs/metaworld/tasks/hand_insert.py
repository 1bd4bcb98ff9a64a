"""Hand insert: carry a small block into a hole in the table (MTBench ``hand_insert``, Meta-World
``hand-insert-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState

TARGET_RADIUS = 0.05
BONUS_REACH = 0.02
# MTBench's openness: finger-tip distance / 0.095, clipped to [0, 1] (the bonus needs it > 0)
OPENNESS_SPAN = 0.095


def hand_insert_reward(action: torch.Tensor, obj: torch.Tensor, goal: torch.Tensor, obj_init: torch.Tensor,
                       tcp: torch.Tensor, left_pad: torch.Tensor, right_pad: torch.Tensor,
                       init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's ``hand_insert`` dense term before its ``* .01`` (``[n]``, in [0, 9])::

        in_place = tol(‖obj − goal‖, (0, .05), margin ‖obj_init − goal‖, long_tail)
        grasp    = caging(obj; obj_radius .02, pad_success_thresh .05, object_reach_radius 0, xz_thresh .005,
                          medium density)
        r = hamacher(grasp, in_place)
        r += 1 + 7·in_place  if ‖obj − tcp‖ < .02 and openness > 0 and ‖goal − tcp‖ < .05

    with ``openness = clip(‖right_pad − left_pad‖ / 0.095, 0, 1)`` (MTBench's finger-tip distance).
    """
    target_to_obj = (obj - goal).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS), margin=(obj_init - goal).norm(dim=-1),
                         sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, obj, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0, xz_thresh=0.005,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=obj_init, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    openness = ((right_pad - left_pad).norm(dim=-1) / OPENNESS_SPAN).clamp(0.0, 1.0)
    bonus = ((obj - tcp).norm(dim=-1) < BONUS_REACH) & (openness > 0) & ((goal - tcp).norm(dim=-1) < TARGET_RADIUS)
    return torch.where(bonus, reward + 1.0 + 7.0 * in_place, reward)


def hand_insert_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖obj − goal‖ < 0.05`` (``[n]`` bool)."""
    return (obj - goal).norm(dim=-1) < TARGET_RADIUS


class HandInsert(FreeObjectTask):
    """Bring the 4 cm block (10 g) into the 16 x 16 cm hole of the table (Meta-World's ``sawyer_table_with_hole.xml``).

    * Scene: the table top is 5 cm thick here (top at z = 0.05) with a square hole, x in [-0.08, 0.08], y in
      [0.76, 0.92], whose floor is at z = 0. MTBench uses the same table asset with its origin at 1.0 m (the top at
      1.05 m), so its heights map to ours by ``z = z_mtb - 1.0`` in this scene (not the usual ``- 1.027``).
    * Reset: block ~ U([-0.1, 0.6, 0.07], [0.1, 0.7, 0.07]), goal ~ U([-0.04, 0.8, 0.0125], [0.04, 0.88, 0.0125])
      (MTBench x_mtb in [0, .1] / [.2, .28], y_mtb in [-.1, .1] / [-.04, .04] mapped; also Meta-World's x-y
      ranges). Goal height: MTBench's 1.0125 m, 1.25 cm above the hole's floor (Meta-World: -0.02, 2 cm below
      it). Block height: resting on the top (MTBench spawns it at its miscomputed surface height 1.0325 m + 2 cm,
      1.75 cm inside the 1.05 m top, from where the simulator pushes it out). No goal rejection (MTBench has none;
      Meta-World resamples goals within 15 cm of the block).
    * Observation: object 1 = the block (position, orientation).
    * Dense reward: :func:`hand_insert_reward` (``dense_scale`` 0.01).
    * Success (MTBench): ``‖block − goal‖ < 0.05``.
    * Differences: the hand starts with its TCP at (0, 0.6, 0.2) (Meta-World's ``hand_init_pos``); ``init_tcp`` is
      recorded at every reset (MTBench: once per run).
    * Needs ``scene.py`` to accept a table without a retaining wall whose top is several boxes (see the report of
      this task's branch).
    """

    name = "hand_insert"
    mtbench_id = 22
    description = "Insert the gripper together with a small block into a hole in the table."
    scene = SceneSpec("sawyer_table_with_hole.xml", hand_init_pos=(0.0, 0.6, 0.2))
    reset_low = (-0.1, 0.6, 0.07, -0.04, 0.8, 0.0125)
    reset_high = (0.1, 0.7, 0.07, 0.04, 0.88, 0.0125)
    MIN_GOAL_DIST = 0.0  # MTBench samples object and goal independently

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return hand_insert_reward(action, s.obj_pos, s.goal, s.obj_init_pos, s.tcp, s.left_pad, s.right_pad,
                                  s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return hand_insert_success(s.obj_pos, s.goal)
