"""Handle press: push the lever handle of a housing down from the front (MTBench ``handle_press``, Meta-World
``handle-press-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import hamacher_product, tolerance
from ..task import MetaWorldTask, TaskState
from ._handle_press import FRONT_RESET_HIGH, FRONT_RESET_LOW, FRONT_SCENE, PRESS_SITE, SLIDE_HIGH, HandleSceneMixin

TARGET_RADIUS = 0.02
HANDLE_RADIUS = 0.02


def handle_press_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, handle_init: torch.Tensor,
                        init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's ``handle_press``/``handle_press_side`` dense term before its ``* .01`` (``[n]``, in [0, 1])::

        in_place = tol(‖handle − goal‖, (0, .02), margin |‖goal − handle_init‖ − .02|, long_tail)
        reach    = tol(‖handle − tcp‖, (0, .02), margin |‖handle − tcp_init‖ − .02|, long_tail)
        r = hamacher(reach, in_place)

    (MTBench measures the reach margin from the *current* handle point to the initial TCP.)
    """
    target_to_obj = (handle - goal).norm(dim=-1)
    target_to_obj_init = (goal - handle_init).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS),
                         margin=(target_to_obj_init - TARGET_RADIUS).abs(), sigmoid="long_tail")
    tcp_to_obj = (handle - tcp).norm(dim=-1)
    tcp_to_obj_init = (handle - init_tcp).norm(dim=-1)
    reach = tolerance(tcp_to_obj, bounds=(0.0, HANDLE_RADIUS), margin=(tcp_to_obj_init - HANDLE_RADIUS).abs(),
                      sigmoid="long_tail")
    return hamacher_product(reach, in_place)


def handle_press_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − goal‖ ≤ 0.02`` (``[n]`` bool)."""
    return (handle - goal).norm(dim=-1) <= TARGET_RADIUS


class HandlePress(HandleSceneMixin, MetaWorldTask):
    """Press the handle down to the ``goalPress`` point (see ``_handle_press`` for the scene).

    * Reset: housing ~ U([-0.1, 0.8, 0], [0.1, 0.9, 0]) (MTBench x_mtb in [.2, .3], y_mtb in [-.1, .1] mapped; also
      Meta-World's range), slide at its upper limit (0). MTBench's reset offsets ``obj_init = housing + (-.216, 0,
      .172)`` and ``target = obj_init - (0, 0, .097)`` are, mapped to our frame, exactly the ``handleStart`` site at
      reset and the ``goalPress`` site (``housing + (0, -0.216, 0.075)``); both are read from the model after reset.
    * Observation: object 1 = the ``handleStart`` site and the handle's orientation; goal = ``goalPress``.
    * Dense reward: :func:`handle_press_reward` (MTBench's term before ``* .01``; ``dense_scale`` 0.01).
    * Success (MTBench): ``‖handle − goal‖ ≤ 0.02``, i.e. the handle pressed by at least 7.7 of its 10 cm.
    * Differences: the hand starts with its TCP at (0, 0.6, 0.2) (Meta-World's ``hand_init_pos``; MTBench starts
      from a per-task joint configuration); ``init_tcp`` is recorded at every reset (MTBench: once per run).
    """

    name = "handle_press"
    mtbench_id = 24
    description = "Press a lever handle down from the front."
    scene = FRONT_SCENE
    reset_low = FRONT_RESET_LOW
    reset_high = FRONT_RESET_HIGH
    SLIDE_RESET = SLIDE_HIGH
    GOAL_SITE = PRESS_SITE

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_press_reward(s.tcp, s.obj_pos, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return handle_press_success(s.obj_pos, s.goal)
