"""Pieces shared by drawer_open and drawer_close (Meta-World ``sawyer_drawer.xml``).

The scene: a cabinet body ``drawer`` placed per world (its ``body_pos`` is batched) with the sliding
``drawer_link`` (joint ``goal_slidey``, axis +y, range [-0.16, 0]: negative = pulled out towards the robot).
With the cabinet at ``p`` and the slide at ``q``, ``drawer_link`` sits at ``p + (0, -0.01 + q, 0.09)``; the
handle bar (a capsule along x, radius 9 mm) is at ``drawer_link + (0, -0.15, 0)`` and the drawer's front wall
spans ``drawer_link + (0, -0.09 .. -0.074, -0.044 .. +0.06)``.

Meta-World reads ``get_body_com("drawer_link")``, which in gymnasium's MuJoCo env is the body *frame* position
``xpos`` (not the centre of mass ``xipos``), so the handle points here are offsets from ``xpos`` too.

The cabinet is fixed to the world: it is moved per world with ``MetaWorldTask.set_body_pos``, which also
translates its collision geoms (MuJoCo Warp computes world-fixed geoms only once; without that the drawer and
the cabinet walls interpenetrate for any cabinet x != 0 and the drawer is shot out against its joint limit).

This module holds only plain functions, constants and a mixin (no ``MetaWorldTask`` subclass, so task discovery
ignores it); the reward functions are pure torch on ``[n, 3]`` tensors so that the tests can evaluate them without
physics.
"""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import hamacher_product, tolerance
from ..scene import SceneSpec, guide_by_joint
from ..task import TaskState

SCENE = SceneSpec("sawyer_drawer.xml", hand_init_pos=(0.0, 0.6, 0.2))
# cabinet position x, y, z (Meta-World drawer-open-v3 / drawer-close-v3: obj_low/obj_high; no goal part)
RESET_LOW = (-0.1, 0.9, 0.0)
RESET_HIGH = (0.1, 0.9, 0.0)
SLIDE_JOINT = "goal_slidey"
CABINET_BODY = "drawer"
DRAWER_BODY = "drawer_link"
# slide travel of the joint (range [-0.16, 0])
SLIDE_TRAVEL = 0.16


def shift(x: torch.Tensor, offset: tuple[float, float, float]) -> torch.Tensor:
    """``x + offset`` for ``[..., 3]`` tensors, with the constant as Python floats (no host-to-device copy)."""
    return torch.stack([x[..., 0] + offset[0], x[..., 1] + offset[1], x[..., 2] + offset[2]], dim=-1)


def scaled_norm(x: torch.Tensor, scale: tuple[float, float, float]) -> torch.Tensor:
    """``‖x · scale‖`` over the last axis (``[..., 3]``)."""
    return torch.stack([x[..., 0] * scale[0], x[..., 1] * scale[1], x[..., 2] * scale[2]], dim=-1).norm(dim=-1)


class DrawerSceneMixin:
    """Model ids and reset writes of the drawer scene; mix into a ``MetaWorldTask`` subclass (listed first)."""

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """The drawer slides on its joint alone (no contacts with its case or the wall behind; stiff limit)."""
        guide_by_joint(spec, DRAWER_BODY, SLIDE_JOINT, ("drawercase_link", "RetainingWall"))

    def bind(self, model) -> None:
        self.slide_qpos = self.joint_qposadr(SLIDE_JOINT)
        self.cabinet_body = self.body_id(CABINET_BODY)
        self.drawer_body = self.body_id(DRAWER_BODY)

    def place_drawer(self, s: TaskState, cabinet: torch.Tensor, slide: float, mask: torch.Tensor) -> None:
        """Move the cabinet to ``cabinet`` ([n, 3]) and set the slide to ``slide`` (velocity is zero after the
        robot reset) in the worlds of ``mask``."""
        self.set_body_pos(s.sim, self.cabinet_body, cabinet, mask)
        q = s.sim.qpos[:, self.slide_qpos]
        q.copy_(torch.where(mask, slide, q))

    def drawer_link_pos(self, s: TaskState) -> torch.Tensor:
        return s.sim.xpos[:, self.drawer_body]


# ------------------------------------------------------------------ drawer_open
OPEN_MAX_DIST = 0.2  # Meta-World's maxDist: the goal is 20 cm in front of the closed handle
OPEN_HANDLE_OFFSET = (0.0, -0.16, 0.0)  # observed handle point relative to drawer_link (Meta-World)
OPEN_GOAL_OFFSET = (0.0, -0.16 - OPEN_MAX_DIST, 0.09)  # goal relative to the cabinet (Meta-World)
OPEN_CAGE_SCALE = (3.0, 3.0, 1.0)
# MTBench success target: the fully open handle (closed handle + 16 cm pull) = goal + (0, 0.2 - 0.16 - 0.01, 0)
OPEN_SUCCESS_FROM_GOAL = (0.0, OPEN_MAX_DIST - SLIDE_TRAVEL - 0.01, 0.0)
OPEN_SUCCESS_RADIUS = 0.035


def drawer_open_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor,
                       init_tcp: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Meta-World v2 ``SawyerDrawerOpenEnvV3.compute_reward`` *without* its final ``* 5``.

    Returns ``(caging + opening, caging, opening)``, each ``[n]``; the first lies in [0, 2].
    """
    handle_error = (handle - goal).norm(dim=-1)
    opening = tolerance(handle_error, bounds=(0.0, 0.02), margin=OPEN_MAX_DIST, sigmoid="long_tail")
    # Meta-World's handle_pos_init = target + (0, maxDist, 0) (1 cm behind the observed closed-handle point)
    handle_init = shift(goal, (0.0, OPEN_MAX_DIST, 0.0))
    gripper_error = scaled_norm(handle - tcp, OPEN_CAGE_SCALE)
    gripper_error_init = scaled_norm(handle_init - init_tcp, OPEN_CAGE_SCALE)
    caging = tolerance(gripper_error, bounds=(0.0, 0.01), margin=gripper_error_init, sigmoid="long_tail")
    return caging + opening, caging, opening


def drawer_open_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − fully-open handle‖ ≤ 0.035`` (see :class:`..drawer_open.DrawerOpen`)."""
    target = shift(goal, OPEN_SUCCESS_FROM_GOAL)
    return (handle - target).norm(dim=-1) <= OPEN_SUCCESS_RADIUS


# ------------------------------------------------------------------ drawer_close
CLOSE_MAX_DIST = 0.15  # Meta-World v3 starts the drawer pulled out by 15 cm
CLOSE_HANDLE_OFFSET = (0.0, -0.16, 0.05)  # observed handle point relative to drawer_link (Meta-World)
CLOSE_GOAL_OFFSET = (0.0, -0.16, 0.09)  # goal relative to the cabinet (Meta-World)
# Meta-World's compute_reward reads self.TARGET_RADIUS, i.e. SawyerXYZEnv's 0.05; the class attribute
# _TARGET_RADIUS = 0.04 of SawyerDrawerCloseEnvV3 is never used
CLOSE_TARGET_RADIUS = 0.05
CLOSE_HANDLE_REACH_RADIUS = 0.005
# MTBench success target: the closed handle point = cabinet + (0, -0.17, 0.14) = goal + (0, -0.01, 0.05)
CLOSE_SUCCESS_FROM_GOAL = (0.0, -0.01, 0.05)
CLOSE_SUCCESS_RADIUS = 0.055


def drawer_close_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, handle_init: torch.Tensor,
                        init_tcp: torch.Tensor, grip_action: torch.Tensor
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Meta-World v2 ``SawyerDrawerCloseEnvV3.compute_reward`` without its success override (``reward = 1``
    when ``‖handle − target‖ ≤ 0.065``). Returns ``(10 · H(H(reach, closed), in_place), reach, in_place)``."""
    target_to_obj = (handle - goal).norm(dim=-1)
    target_to_obj_init = (handle_init - goal).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, CLOSE_TARGET_RADIUS),
                         margin=(target_to_obj_init - CLOSE_TARGET_RADIUS).abs(), sigmoid="long_tail")
    tcp_to_obj = (handle - tcp).norm(dim=-1)
    tcp_to_obj_init = (handle_init - init_tcp).norm(dim=-1)
    reach = tolerance(tcp_to_obj, bounds=(0.0, CLOSE_HANDLE_REACH_RADIUS),
                      margin=(tcp_to_obj_init - CLOSE_HANDLE_REACH_RADIUS).abs(), sigmoid="gaussian")
    gripper_closed = grip_action.clamp(0.0, 1.0)
    reach = hamacher_product(reach, gripper_closed)
    return 10.0 * hamacher_product(reach, in_place), reach, in_place


def drawer_close_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − closed handle‖ ≤ 0.055`` (see :class:`..drawer_close.DrawerClose`)."""
    target = shift(goal, CLOSE_SUCCESS_FROM_GOAL)
    return (handle - target).norm(dim=-1) <= CLOSE_SUCCESS_RADIUS
