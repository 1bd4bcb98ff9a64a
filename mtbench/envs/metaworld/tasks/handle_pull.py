"""Handle pull: pull the pressed-down lever handle of a housing up from the front (MTBench ``handle_pull``,
Meta-World ``handle-pull-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..task import MetaWorldTask, TaskState
from ._handle_press import FRONT_RESET_HIGH, FRONT_RESET_LOW, FRONT_SCENE, PULL_SITE, SLIDE_LOW, HandleSceneMixin

TARGET_RADIUS = 0.005  # MTBench: "changed from .05 to make task harder"
BONUS_REACH = 0.035
# MTBench's "lifted" test reads ``obj_pos[:, 0] - .01 > obj_init_pos[:, 2]``: its x (forward) coordinate against
# the initial height. In our frame x_mtb = y - 0.6 and z_mtb = z + 1.027, so the test is
# ``handle_y - 0.6 - 0.01 > handle_init_z + 1.027``, which no reachable state satisfies (see HandlePull).
MTB_X_FROM_Y = -0.6
MTB_Z_FROM_Z = 1.027


def handle_pull_reward(action: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, handle_init: torch.Tensor,
                       tcp: torch.Tensor, left_pad: torch.Tensor, right_pad: torch.Tensor, init_tcp: torch.Tensor,
                       finger_opening: torch.Tensor) -> torch.Tensor:
    """MTBench's ``handle_pull`` dense term before its ``* .01`` (``[n]``, in [0, 7])::

        in_place = tol(‖goal − handle‖, (0, .005), margin ‖goal − handle_init‖, long_tail)
        grasp    = caging(handle; obj_radius .022, pad_success_thresh .05, object_reach_radius .01, xz_thresh .01,
                          medium density)
        r = hamacher(grasp, in_place)
        r += 1 + 5·in_place  if ‖handle − tcp‖ < .035 and finger_opening > 0 and (MTBench's test, literal:)
                               handle_y − 0.6 − .01 > handle_init_z + 1.027
    """
    target_to_obj = (goal - handle).norm(dim=-1)
    target_to_obj_init = (goal - handle_init).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS), margin=target_to_obj_init, sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, handle, obj_radius=0.022, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.01,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=handle_init, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    tcp_to_obj = (handle - tcp).norm(dim=-1)
    paper_lift_test = handle[:, 1] + MTB_X_FROM_Y - 0.01 > handle_init[:, 2] + MTB_Z_FROM_Z
    bonus = (tcp_to_obj < BONUS_REACH) & (finger_opening > 0) & paper_lift_test
    return torch.where(bonus, reward + 1.0 + 5.0 * in_place, reward)


def handle_pull_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖goal − handle‖ < 0.005`` (``[n]`` bool)."""
    return (goal - handle).norm(dim=-1) < TARGET_RADIUS


class HandlePull(HandleSceneMixin, MetaWorldTask):
    """Pull the pressed-down handle up to ``goalPull`` (see ``_handle_press`` for the scene).

    * Reset: housing ~ U([-0.1, 0.8, 0], [0.1, 0.9, 0]) (MTBench's range mapped; Meta-World's), slide at its lower
      limit (-0.1, pressed down). MTBench's ``obj_init = housing + (-.216, 0, .072)`` and ``target = obj_init + (0,
      0, .1)`` are, in our frame, the ``handleStart`` site at reset and the ``goalPull`` site (``housing + (0,
      -0.216, 0.172)``: the handle fully up), read from the model after reset.
    * Observation: object 1 = ``handleStart`` and the handle's orientation (MTBench; Meta-World observes
      ``handleRight``); goal = ``goalPull``.
    * Dense reward: :func:`handle_pull_reward` (``dense_scale`` 0.01). MTBench's caging reward takes the pads along
      its x axis, which is our y: the Panda's pads close across the grip bar (along x) as in MTBench.
      ``finger_opening`` is MTBench's ``(q_finger1 + q_finger2) / 0.08`` from the Panda's finger joints.
    * MTBench's bonus condition compares the handle's *forward* coordinate with the initial *height* (a typo for
      ``obj_pos[:, 2]``, which handle_pull_side has). Kept literally for parity with the paper-era reward: in our
      frame it needs ``handle_y > handle_init_z + 1.637``, so the ``1 + 5·in_place`` bonus is never paid (as in
      MTBench, where x_mtb < 0.1 and z_init_mtb ≈ 1.1). The dense reward is therefore at most 1.
    * Success (MTBench): ``‖goal − handle‖ < 0.005``, the handle within 5 mm of the top of its travel.
    * Differences: the hand starts at (0, 0.6, 0.2) (Meta-World's ``hand_init_pos``); ``init_tcp`` is recorded at
      every reset (MTBench: once per run).
    """

    name = "handle_pull"
    mtbench_id = 26
    description = "Pull a lever handle up from the front."
    scene = FRONT_SCENE
    reset_low = FRONT_RESET_LOW
    reset_high = FRONT_RESET_HIGH
    SLIDE_RESET = SLIDE_LOW
    GOAL_SITE = PULL_SITE

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_pull_reward(action, s.obj_pos, s.goal, s.obj_init_pos, s.tcp, s.left_pad, s.right_pad,
                                  s.init_tcp, self.finger_opening(s))

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_pull_success(s.obj_pos, s.goal)
