"""Handle press side: push the lever handle of a sideways housing down (MTBench ``handle_press_side``, Meta-World
``handle-press-side-v3``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState
from ._handle_press import PRESS_SITE, SIDE_RESET_HIGH, SIDE_RESET_LOW, SIDE_SCENE, SLIDE_HIGH, HandleSceneMixin
from .handle_press import handle_press_reward, handle_press_success


class HandlePressSide(HandleSceneMixin, MetaWorldTask):
    """Press the handle of the sideways housing down to ``goalPress`` (see ``_handle_press`` for the scene).

    * Reset: housing ~ U([-0.35, 0.65, 0], [-0.25, 0.75, 0]) (MTBench x_mtb in [.05, .15], y_mtb in [.25, .35]
      mapped; also Meta-World's range), turned by +90 degrees about z so that the lever points to +x (MTBench's
      unrotated side asset, mapped), slide at its upper limit. MTBench's ``obj_init = housing + (0, -.216, .172)``
      and ``target = obj_init - (0, 0, .097)`` (its frame) are the ``handleStart`` site at reset and the
      ``goalPress`` site (``housing + (0.216, 0, 0.075)`` in ours), read from the model after reset.
    * Observation, reward and success: as :class:`..handle_press.HandlePress` (MTBench uses the same formula:
      ``hamacher(reach, in_place)``, success ``‖handle − goal‖ ≤ 0.02``).
    * Differences: the hand starts at (0, 0.6, 0.2) (Meta-World's ``hand_init_pos``); the housing's turn is
      Meta-World's ``euler = 1.57`` rad (0.8 mrad short of MTBench's 90 degrees).
    """

    name = "handle_press_side"
    mtbench_id = 23
    description = "Press a lever handle down from the side."
    scene = SIDE_SCENE
    reset_low = SIDE_RESET_LOW
    reset_high = SIDE_RESET_HIGH
    SLIDE_RESET = SLIDE_HIGH
    GOAL_SITE = PRESS_SITE

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_press_reward(s.tcp, s.obj_pos, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_press_success(s.obj_pos, s.goal)
