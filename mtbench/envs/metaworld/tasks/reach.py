"""Reach: move the TCP to a goal in the air (Meta-World ``reach-v3``)."""

from __future__ import annotations


from ..reward_utils import tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask


class Reach(FreeObjectTask):
    name = "reach"
    scene = SceneSpec("sawyer_reach_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # object x, y, z then goal x, y, z (Meta-World reach-v3 ranges, Meta-World frame: y forward, table at z=0)
    reset_low = (-0.1, 0.6, 0.02, -0.1, 0.8, 0.05)
    reset_high = (0.1, 0.7, 0.02, 0.1, 0.9, 0.3)
    TARGET_RADIUS = 0.05

    def evaluate(self, s, action, obs):
        tcp_to_target = (s.tcp - s.goal).norm(dim=-1)
        margin = (s.init_tcp - s.goal).norm(dim=-1)
        in_place = tolerance(tcp_to_target, bounds=(0.0, self.TARGET_RADIUS), margin=margin, sigmoid="long_tail")
        return 10.0 * in_place, tcp_to_target <= self.TARGET_RADIUS
