"""Reach: move the TCP to a goal in the air (Meta-World ``reach-v3``, MTBench ``task_fns/reach.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState

TARGET_RADIUS = 0.05


def reach_reward(tcp: torch.Tensor, goal: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """``10 · tolerance(‖tcp − goal‖, (0, 0.05), margin=‖init_tcp − goal‖, long_tail)`` (Meta-World v2)."""
    in_place = tolerance((tcp - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=(init_tcp - goal).norm(dim=-1), sigmoid="long_tail")
    return 10.0 * in_place


def reach_success(tcp: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖tcp − goal‖ ≤ 0.05``."""
    return (tcp - goal).norm(dim=-1) <= TARGET_RADIUS


class Reach(FreeObjectTask):
    """Move the TCP into a 5 cm ball around the goal.

    * Reset: the (unused) puck at x ~ U[-0.1, 0.1], y ~ U[0.6, 0.7], z = 0.02; goal x ~ U[-0.1, 0.1],
      y ~ U[0.8, 0.9], z ~ U[0.05, 0.3] (Meta-World reach-v3 ranges in Meta-World's frame: y forward, table top at
      z = 0; MTBench's frame is x_mtb = y − 0.6, y_mtb = −x, z_mtb = z + 1.027, same ranges).
    * Objects: the puck's pose (as Meta-World reports it).
    * Dense reward: Meta-World's ``10 · in_place``; ``dense_scale`` 0.01.
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
