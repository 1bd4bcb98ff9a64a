"""Reach: move the TCP to a goal in the air (Meta-World ``reach-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..scene import SceneSpec
from ..task import MetaWorldTask, TaskState, pad_object_state


class Reach(MetaWorldTask):
    name = "reach"
    scene = SceneSpec("sawyer_reach_v3.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # object x, y, z then goal x, y, z (Meta-World reach-v3 ranges, Meta-World frame: y forward, table at z=0)
    reset_low = (-0.1, 0.6, 0.02, -0.1, 0.8, 0.05)
    reset_high = (0.1, 0.7, 0.02, 0.1, 0.9, 0.3)
    TARGET_RADIUS = 0.05

    def bind(self, model) -> None:
        self.obj_qpos = self.joint_qposadr("objjoint")
        self.obj_body = self.body_id("obj")

    def sample(self, n, generator, device):
        # Meta-World rejects goals closer than 15 cm (in xy) to the object; resample those a few times
        vec = super().sample(n, generator, device)
        for _ in range(8):
            close = (vec[:, :2] - vec[:, 3:5]).norm(dim=-1) < 0.15
            vec = torch.where(close[:, None], super().sample(n, generator, device), vec)
        return vec

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.set_free_body(s.sim, self.obj_qpos, vec[:, :3], mask)
        s.obj_init_pos.copy_(torch.where(mask[:, None], vec[:, :3], s.obj_init_pos))
        s.goal.copy_(torch.where(mask[:, None], vec[:, 3:6], s.goal))

    def object_state(self, s: TaskState) -> torch.Tensor:
        return pad_object_state(self.body_pose(s, self.obj_body))

    def evaluate(self, s, action, obs):
        tcp_to_target = (s.tcp - s.goal).norm(dim=-1)
        margin = (s.init_tcp - s.goal).norm(dim=-1)
        in_place = tolerance(tcp_to_target, bounds=(0.0, self.TARGET_RADIUS), margin=margin, sigmoid="long_tail")
        return 10.0 * in_place, tcp_to_target <= self.TARGET_RADIUS
