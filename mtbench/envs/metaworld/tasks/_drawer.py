"""Pieces shared by drawer_open and drawer_close (Meta-World ``sawyer_drawer.xml``).

The scene: a cabinet body ``drawer`` placed per world (its ``body_pos`` is batched) with the sliding
``drawer_link`` (joint ``goal_slidey``, axis +y, range [-0.16, 0]: negative = pulled out towards the robot).
With the cabinet at ``p`` and the slide at ``q``, ``drawer_link`` sits at ``p + (0, -0.01 + q, 0.09)``; the
handle bar (a capsule along x, radius 9 mm) is at ``drawer_link + (0, -0.15, 0)`` and the drawer's front wall
spans ``drawer_link + (0, -0.09 .. -0.074, -0.044 .. +0.06)``.

Meta-World reads ``get_body_com("drawer_link")``, which in gymnasium's MuJoCo env is the body *frame* position
``xpos`` (not the centre of mass ``xipos``), so the handle points here are offsets from ``xpos`` too.

This module holds only plain functions, constants and helpers (no ``MetaWorldTask`` subclass, so task discovery
ignores it); the reward functions are pure torch on ``[n, 3]`` tensors so that the tests can evaluate them without
physics. :class:`StaticFixture` (also used by the window tasks) works around MuJoCo Warp's static geoms.
"""

from __future__ import annotations

import mujoco
import numpy as np
import torch
import warp as wp

from ..reward_utils import hamacher_product, tolerance
from ..scene import SceneSpec
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


_GEOM_XPOS_KEY = "_geom_xpos_view"


class StaticFixture:
    """Moves a fixture body that is welded to the world (e.g. the drawer cabinet) per world, *with* its geoms.

    ``MetaWorldTask.set_body_pos`` writes the batched ``body_pos``; kinematics then move the body, its sites and
    every jointed descendant. But MuJoCo Warp treats geoms of bodies welded to the world as static: their
    ``geom_xpos``/``geom_xmat`` are computed once in ``put_data`` and never again (``smooth._geom_local_to_global``
    skips them). Without this fix the cabinet's walls stay at the model's default position while the drawer moves
    with the new ``body_pos``, so the two interpenetrate (the drawer was shot out against its joint limit at
    cabinet x = -0.1) and the robot collides with invisible walls. :meth:`place` therefore also writes
    ``geom_xpos`` of the static geoms in the fixture's subtree (a pure translation; their orientation is
    unchanged). ``reset`` does not touch ``geom_xpos``, so the written values persist.
    """

    def __init__(self, model: mujoco.MjModel, body: int) -> None:
        if model.body_parentid[body] != 0:
            raise ValueError(f"fixture body {model.body(body).name!r} must be a child of the world body")
        self.body = body
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        subtree = {body}
        for b in range(body + 1, model.nbody):  # bodies are numbered depth-first: descendants follow their parent
            if model.body_parentid[b] in subtree:
                subtree.add(b)
        static = [g for g in range(model.ngeom)
                  if model.geom_bodyid[g] in subtree and model.body_weldid[model.geom_bodyid[g]] == 0
                  and model.body_mocapid[model.body_rootid[model.geom_bodyid[g]]] == -1]
        self._geoms = np.asarray(static, dtype=np.int64)
        # static geom positions relative to the body's position parameter (its parent is the world)
        self._offsets = (data.geom_xpos[static] - model.body_pos[body]).astype(np.float32)
        self._device_consts: dict[torch.device, tuple[torch.Tensor, torch.Tensor]] = {}

    def _consts(self, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
        if device not in self._device_consts:
            self._device_consts[device] = (torch.as_tensor(self._geoms, device=device),
                                           torch.as_tensor(self._offsets, device=device))
        return self._device_consts[device]

    def place(self, s: TaskState, pos: torch.Tensor, mask: torch.Tensor) -> None:
        """Put the fixture at ``pos`` (``[n, 3]``, its ``body_pos``) in the worlds of ``mask``."""
        field = s.sim.model_field("body_pos")[:, self.body]
        field.copy_(torch.where(mask[:, None], pos, field))
        if len(self._geoms) == 0:
            return
        geoms, offsets = self._consts(pos.device)
        geom_xpos = s.extra.get(_GEOM_XPOS_KEY)
        if geom_xpos is None:  # zero-copy view of the simulator's geom positions, made once per block
            geom_xpos = s.extra[_GEOM_XPOS_KEY] = wp.to_torch(s.sim.data.geom_xpos)
        new = pos[:, None, :] + offsets[None]
        geom_xpos[:, geoms] = torch.where(mask[:, None, None], new, geom_xpos[:, geoms])


class DrawerSceneMixin:
    """Model ids and reset writes of the drawer scene; mix into a ``MetaWorldTask`` subclass (listed first)."""

    def bind(self, model) -> None:
        self.slide_qpos = self.joint_qposadr(SLIDE_JOINT)
        self.cabinet_body = self.body_id(CABINET_BODY)
        self.drawer_body = self.body_id(DRAWER_BODY)
        self.cabinet = StaticFixture(model, self.cabinet_body)

    def place_drawer(self, s: TaskState, cabinet: torch.Tensor, slide: float, mask: torch.Tensor) -> None:
        """Move the cabinet to ``cabinet`` ([n, 3]) and set the slide to ``slide`` (velocity is zero after the
        robot reset) in the worlds of ``mask``."""
        self.cabinet.place(s, cabinet, mask)
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
