"""Door unlock: turn the safe's lock lever up (Meta-World ``door-unlock-v3``, MTBench id 15)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..task import MetaWorldTask, TaskState, offset
from ._lock import LOCK_LENGTH, LOCKED, RESET_HIGH, RESET_LOW, SCENE, LockSceneMixin, edit_lock_scene

GOAL_FROM_HINGE = (0.1, -0.04, 0.0)  # MTBench: obj_init_pos + (-.04, -.1, 0) in its frame (= Meta-World)
SUCCESS_TOL = 0.02


def door_unlock_reward(tcp: torch.Tensor, obj: torch.Tensor, init_tcp: torch.Tensor, hinge: torch.Tensor,
                       goal: torch.Tensor) -> torch.Tensor:
    """MTBench ``door_unlock`` dense term before its ``* .01`` (``[n]``; MTBench's ``scale`` is (1, 1, 1) and its
    shoulder offset removed)::

        ready_to_push = tol(‖tcp − obj‖, (0, .02), margin ‖init_tcp − hinge‖, long_tail)
        pushed        = tol(|goal_x − obj_x|, (0, .005), margin .1, long_tail)
        r = 2 · ready_to_push + 8 · pushed
    """
    ready_to_push = tolerance((tcp - obj).norm(dim=-1), bounds=(0.0, 0.02), margin=(init_tcp - hinge).norm(dim=-1),
                              sigmoid="long_tail")
    pushed = tolerance((goal[..., 0] - obj[..., 0]).abs(), bounds=(0.0, 0.005), margin=LOCK_LENGTH,
                       sigmoid="long_tail")
    return 2.0 * ready_to_push + 8.0 * pushed


def door_unlock_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``|goal_x − obj_x| <= 0.02`` (the lever turned up to within about 0.37 rad of horizontal)."""
    return (goal[..., 0] - obj[..., 0]).abs() <= SUCCESS_TOL


class DoorUnlock(LockSceneMixin, MetaWorldTask):
    """Turn the lock lever from hanging down (locked) up towards horizontal.

    * Scene: Meta-World ``sawyer_door_lock.xml`` (see ``_lock``); the hand starts at (0, 0.6, 0.3).
    * Reset: safe at x ~ U[-0.1, 0.1], y ~ U[0.8, 0.85], z = 0.15 (MTBench, = Meta-World v3); lever at 1.57
      (MTBench: the joint's upper limit; Meta-World 1.5708). ``obj_init_pos`` = the lever's hinge,
      ``safe + (0, -0.118, 0.061)``; goal = ``obj_init_pos + (0.1, -0.04, 0)`` (MTBench ``(-.04, -.1, 0)``: the
      lever's end turned up to horizontal).
    * Observation: object 1 = ``lockStartUnlock`` (lever frame ``(0.09, -0.04, -0.01)``) and the lever's quaternion.
    * Dense reward: :func:`door_unlock_reward` (MTBench before ``* .01``); MTBench's ``obj_to_target`` compares
      y_mtb, i.e. our x.
    * Success: ``|goal_x − obj_x| <= 0.02``, reached for lever angles below about 0.37 rad; success steps pay 10.
    * Differences: ``init_tcp`` per reset (MTBench: once); Meta-World's ``tolerance`` inside the bounds (MTBench's
      returns 0 there when the margin is positive); the hand starts 10 cm above Meta-World's start (see ``_lock``).
    """

    name = "door_unlock"
    mtbench_id = 15
    description = "Turn the door's lock lever upward to unlock the door."
    scene = SCENE
    reset_low = RESET_LOW
    reset_high = RESET_HIGH
    LOCK_SITE = "lockStartUnlock"
    LOCK_START = LOCKED

    @classmethod
    def edit_spec(cls, spec) -> None:
        edit_lock_scene(spec)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        hinge = self.place_safe(s, vec[:, :3], mask)
        self.masked_set(s.goal, offset(hinge, *GOAL_FROM_HINGE), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_unlock_reward(s.tcp, s.obj_pos, s.init_tcp, s.obj_init_pos, s.goal)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_unlock_success(s.obj_pos, s.goal)
