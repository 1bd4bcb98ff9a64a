"""Door lock: turn the safe's lock lever down (Meta-World ``door-lock-v3``, MTBench id 14)."""

from __future__ import annotations

import torch

from ..reward_utils import hamacher_product, mtbench_gripper_openness, scaled_norm, tolerance
from ..task import MetaWorldTask, TaskState, offset
from ._lock import LOCK_LENGTH, RESET_HIGH, RESET_LOW, SCENE, LockSceneMixin, edit_lock_scene

GOAL_FROM_HINGE = (0.0, -0.04, -0.1)  # MTBench: obj_init_pos + (-.04, 0, -.1) in its frame (= Meta-World)
NEAR_SCALE = (0.25, 1.0, 0.5)  # MTBench's scale (1, .25, .5) for (x_mtb, y_mtb, z): our (x, y, z) = (y_mtb, x_mtb, z)
SUCCESS_TOL = 0.02


def door_lock_reward(tcp: torch.Tensor, obj: torch.Tensor, init_tcp: torch.Tensor, goal: torch.Tensor,
                     tcp_opened: torch.Tensor) -> torch.Tensor:
    """MTBench ``door_lock`` dense term before its ``* .01`` (``[n]``)::

        near_lock    = tol(‖(obj − tcp)·s‖, (0, .01), margin ‖(obj − init_tcp)·s‖, long_tail),  s = (.25, 1, .5)
        lock_pressed = tol(|goal_z − obj_z|, (0, .005), margin .1, long_tail)
        r = 2 · H(tcp_opened, near_lock) + 8 · lock_pressed
    """
    near_lock = tolerance(scaled_norm(obj - tcp, NEAR_SCALE), bounds=(0.0, 0.01),
                          margin=scaled_norm(obj - init_tcp, NEAR_SCALE), sigmoid="long_tail")
    lock_pressed = tolerance((goal[..., 2] - obj[..., 2]).abs(), bounds=(0.0, 0.005), margin=LOCK_LENGTH,
                             sigmoid="long_tail")
    return 2.0 * hamacher_product(tcp_opened, near_lock) + 8.0 * lock_pressed


def door_lock_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``|goal_z − obj_z| <= 0.02`` (the lever turned down by at least 1.2 rad; ``[n]`` bool)."""
    return (goal[..., 2] - obj[..., 2]).abs() <= SUCCESS_TOL


class DoorLock(LockSceneMixin, MetaWorldTask):
    """Turn the lock lever from horizontal (unlocked) down towards vertical.

    * Scene: Meta-World ``sawyer_door_lock.xml`` (see ``_lock``); the hand starts at (0, 0.6, 0.3).
    * Reset: safe at x ~ U[-0.1, 0.1], y ~ U[0.8, 0.85], z = 0.15 (MTBench, = Meta-World v3); lever at 0
      (MTBench: the joint's lower limit). ``obj_init_pos`` = the lever's hinge, ``safe + (0, -0.118, 0.061)``;
      goal = ``obj_init_pos + (0, -0.04, -0.1)`` (MTBench ``(-.04, 0, -.1)``: the lever's end turned down).
    * Observation: object 1 = ``lockStartLock`` (lever frame ``(0.09, -0.04, 0.01)``) and the lever's quaternion.
    * Dense reward: :func:`door_lock_reward` (MTBench before ``* .01``; MTBench's ``scale`` (1, .25, .5) over
      (x_mtb, y_mtb, z) is (0.25, 1, 0.5) over our (x, y, z); openness ``‖pads‖ / 0.095``).
    * Success: ``|goal_z − obj_z| <= 0.02``, reached for lever angles above about 1.2 rad; success steps pay 10.
    * Differences: ``init_tcp`` per reset (MTBench: once); Meta-World's ``tolerance`` inside the bounds (MTBench's
      returns 0 there when the margin is positive); the hand starts 10 cm above Meta-World's start (see ``_lock``).
    """

    name = "door_lock"
    mtbench_id = 14
    description = "Turn the door's lock lever downward to lock the door."
    scene = SCENE
    reset_low = RESET_LOW
    reset_high = RESET_HIGH
    LOCK_SITE = "lockStartLock"
    LOCK_START = 0.0

    @classmethod
    def edit_spec(cls, spec) -> None:
        edit_lock_scene(spec)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        hinge = self.place_safe(s, vec[:, :3], mask)
        self.masked_set(s.goal, offset(hinge, *GOAL_FROM_HINGE), mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_lock_reward(s.tcp, s.obj_pos, s.init_tcp, s.goal,
                                mtbench_gripper_openness(s.left_pad, s.right_pad))

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return door_lock_success(s.obj_pos, s.goal)
