"""Reach: move the TCP to a goal in the air (MTBench ``task_fns/reach.py``; Meta-World ``reach-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState

TARGET_RADIUS = 0.05


def reach_reward(tcp: torch.Tensor, goal: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's dense term (before its ``* 0.01``): ``in_place = tolerance(‖tcp − goal‖, (0, 0.05),
    margin=‖init_tcp − goal‖, long_tail)``, in [0, 1]."""
    return tolerance((tcp - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS), margin=(init_tcp - goal).norm(dim=-1),
                     sigmoid="long_tail")


def reach_success(tcp: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖tcp − goal‖ ≤ 0.05``."""
    return (tcp - goal).norm(dim=-1) <= TARGET_RADIUS


class Reach(FreeObjectTask):
    """Move the TCP into a 5 cm ball around the goal.

    * Reset: the (unused) puck at x ~ U[-0.1, 0.1], y ~ U[0.6, 0.7], z = 0.02; goal x ~ U[-0.1, 0.1],
      y ~ U[0.8, 0.9], z ~ U[0.05, 0.3]. These are MTBench's ranges (obj x_mtb [0, .1], y_mtb [-.1, .1]; goal
      x_mtb [.2, .3], z_mtb [T + .05, T + .3]) in Meta-World's frame (``x_mtb = y − 0.6``, ``y_mtb = −x``,
      ``z_mtb = z + 1.027``), which equal Meta-World reach-v3's.
    * Objects: the puck's pose (as MTBench and Meta-World report it).
    * Dense reward (paper-era MTBench): ``in_place`` in [0, 1], times ``dense_scale`` 0.01 and ``reward_scale``.
      (Meta-World's v2 reward is ``10 · in_place``.)
    * Success: ``‖tcp − goal‖ ≤ 0.05`` (MTBench and Meta-World).
    """

    name = "reach"
    mtbench_id = 40
    description = "Move the gripper to reach a goal position in the air."
    scene = SceneSpec("sawyer_reach_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    reset_low = (-0.1, 0.6, 0.02, -0.1, 0.8, 0.05)
    reset_high = (0.1, 0.7, 0.02, 0.1, 0.9, 0.3)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return reach_reward(s.tcp, s.goal, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return reach_success(s.tcp, s.goal)
