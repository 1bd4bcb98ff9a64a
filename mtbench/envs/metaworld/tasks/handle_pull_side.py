"""Handle pull side: pull the pressed-down handle of a sideways housing up (MTBench ``handle_pull_side``,
Meta-World ``handle-pull-side-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, hamacher_product, tolerance
from ..task import MetaWorldTask, TaskState
from ._handle_press import PULL_SITE, SIDE_RESET_HIGH, SIDE_RESET_LOW, SIDE_SCENE, SLIDE_LOW, HandleSceneMixin

TARGET_RADIUS = 0.005
BONUS_REACH = 0.035


def handle_pull_side_reward(action: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor,
                            handle_init: torch.Tensor, tcp: torch.Tensor, left_pad: torch.Tensor,
                            right_pad: torch.Tensor, init_tcp: torch.Tensor, finger_opening: torch.Tensor
                            ) -> torch.Tensor:
    """MTBench's ``handle_pull_side`` dense term before its ``* .01`` (``[n]``, in [0, 7])::

        in_place = tol(‖(goal − handle)·scale‖, (0, .005), margin ‖(goal − handle_init)·scale‖, long_tail)
        grasp    = caging(handle; obj_radius .032, pad_success_thresh .06, object_reach_radius .01, xz_thresh .01,
                          medium density)
        r = hamacher(grasp, in_place)
        r += 1 + 5·in_place  if ‖handle − tcp‖ < .035 and finger_opening > 0 and handle_z − .01 > handle_init_z

    with MTBench's ``scale = (1, 1, 1)`` (``franka_base.py``), i.e. plain distances.
    """
    target_to_obj = (goal - handle).norm(dim=-1)
    target_to_obj_init = (goal - handle_init).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS), margin=target_to_obj_init, sigmoid="long_tail")
    grasp = gripper_caging_reward(
        action, handle, obj_radius=0.032, pad_success_thresh=0.06, object_reach_radius=0.01, xz_thresh=0.01,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=handle_init, init_tcp=init_tcp,
        medium_density=True,
    )
    reward = hamacher_product(grasp, in_place)
    tcp_to_obj = (handle - tcp).norm(dim=-1)
    lifted = handle[:, 2] - 0.01 > handle_init[:, 2]
    bonus = (tcp_to_obj < BONUS_REACH) & (finger_opening > 0) & lifted
    return torch.where(bonus, reward + 1.0 + 5.0 * in_place, reward)


def handle_pull_side_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖(goal − handle)·scale‖ < 0.005`` with scale (1, 1, 1) (``[n]`` bool)."""
    return (goal - handle).norm(dim=-1) < TARGET_RADIUS


class HandlePullSide(HandleSceneMixin, MetaWorldTask):
    """Pull the pressed-down handle of the sideways housing up to ``goalPull`` (see ``_handle_press``).

    * Reset: housing ~ U([-0.35, 0.65, 0], [-0.25, 0.75, 0]) (MTBench's range mapped; Meta-World's), lever
      pointing to +x, slide at its lower limit (-0.1). MTBench's ``obj_init = housing + (0, -.216, .072)`` and
      ``target = obj_init + (0, 0, .1)`` (its frame) are the ``handleStart`` site at reset and the ``goalPull``
      site (``housing + (0.216, 0, 0.172)`` in ours), read from the model after reset. MTBench's reset space has a
      goal part (x_mtb in [0, .5]) that nothing reads; it is left out here.
    * Observation: object 1 = ``handleStart`` and the handle's orientation (Meta-World observes
      ``handleCenter``); goal = ``goalPull``.
    * Dense reward: :func:`handle_pull_side_reward` (``dense_scale`` 0.01); ``finger_opening`` is MTBench's
      ``(q_finger1 + q_finger2) / 0.08`` from the Panda's finger joints.
    * Success (MTBench): the handle within 5 mm of the top of its travel.
    * Physics note: the grip bar lies along y here, the axis along which the Panda's fingers open, so the fingers
      cannot close across it; the scripted policy pinches the lever arm (6.4 cm wide in y) instead.
    * Differences: the hand starts at (0, 0.6, 0.2) (Meta-World's ``hand_init_pos``); ``init_tcp`` is recorded at
      every reset (MTBench: once per run).
    """

    name = "handle_pull_side"
    mtbench_id = 25
    description = "Pull a lever handle up from the side."
    scene = SIDE_SCENE
    reset_low = SIDE_RESET_LOW
    reset_high = SIDE_RESET_HIGH
    SLIDE_RESET = SLIDE_LOW
    GOAL_SITE = PULL_SITE

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_pull_side_reward(action, s.obj_pos, s.goal, s.obj_init_pos, s.tcp, s.left_pad, s.right_pad,
                                       s.init_tcp, self.finger_opening(s))

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_pull_side_success(s.obj_pos, s.goal)
