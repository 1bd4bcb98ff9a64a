"""Reach-wall: move the TCP to a goal behind a short wall (Meta-World ``reach-wall-v3``, MTBench
``task_fns/reach_wall.py``)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, TaskState

TARGET_RADIUS = 0.05


def reach_wall_reward(tcp: torch.Tensor, goal: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench: ``tolerance(‖tcp − goal‖, (0, 0.05), margin=‖init_tcp − goal‖, long_tail)`` (0..1; Meta-World v2
    pays ten times that)."""
    return tolerance((tcp - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                     margin=(init_tcp - goal).norm(dim=-1), sigmoid="long_tail")


def reach_wall_success(tcp: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖tcp − goal‖ ≤ 0.05``."""
    return (tcp - goal).norm(dim=-1) <= TARGET_RADIUS


class ReachWall(FreeObjectTask):
    """Move the TCP into a 5 cm ball around a goal in the air behind Meta-World's brick wall (see ``_wall``).

    * Reset (MTBench ``create_envs``, mapped ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): the unused
      puck (Meta-World's cylinder r 3 cm, h 3 cm) at x ~ U[-0.05, 0.05], y ~ U[0.6, 0.65], z = 0.015 (resting;
      MTBench: its 4 cm cylinder at 0.02); goal
      x ~ U[-0.05, 0.05], y ~ U[0.85, 0.9], z ~ U[0.05, 0.3]: Meta-World reach-wall-v3's ranges. Pairs closer than
      15 cm in xy are resampled (Meta-World's loop; it cannot trigger with these ranges; MTBench has none).
    * Objects: the puck's pose (as Meta-World; MTBench also reported the wall's pose as object 2).
    * Dense reward (MTBench, before its ``× 0.01`` = ``dense_scale``): ``in_place = tolerance(‖tcp − goal‖, (0,
      0.05), margin=‖init_tcp − goal‖, long_tail)`` in [0, 1] (Meta-World: ``10 · in_place``). ``init_tcp`` is the
      TCP at the episode start (MTBench kept the first episode's for all episodes).
    * Success: ``‖tcp − goal‖ ≤ 0.05`` (MTBench and Meta-World).
    * Scene: Meta-World's wall (x in [-0.02, 0.22], 12 cm tall); MTBench's stood across x in [-0.12, 0.12], 9 cm
      tall. The hand (20 cm long along y, its underside 3.7 cm above the TCP) must not sink behind the wall with
      its rear end inside it: the scripted policy stays 11 cm behind the wall's back face when low.
    """

    name = "reach_wall"
    mtbench_id = 41
    description = "Reach a goal position on the other side of a short wall."
    scene = SceneSpec("sawyer_reach_wall_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # puck x, y, z then goal x, y, z
    reset_low = (-0.05, 0.6, 0.015, -0.05, 0.85, 0.05)
    reset_high = (0.05, 0.65, 0.015, 0.05, 0.9, 0.3)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return reach_wall_reward(s.tcp, s.goal, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return reach_wall_success(s.tcp, s.goal)
