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

This private module holds the scene's constants and a mixin shared by the two drawer task files (task discovery
ignores modules whose name starts with ``_``); each task's reward and success live in its own file.
"""

from __future__ import annotations

import mujoco
import torch

from ..scene import SceneSpec, guide_by_joint
from ..task import TaskState, offset

SCENE = SceneSpec("sawyer_drawer.xml", hand_init_pos=(0.0, 0.6, 0.2))
# cabinet position x, y, z (Meta-World drawer-open-v3 / drawer-close-v3: obj_low/obj_high; no goal part)
RESET_LOW = (-0.1, 0.9, 0.0)
RESET_HIGH = (0.1, 0.9, 0.0)
SLIDE_JOINT = "goal_slidey"
CABINET_BODY = "drawer"
DRAWER_BODY = "drawer_link"
# slide travel of the joint (range [-0.16, 0])
SLIDE_TRAVEL = 0.16


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
        self.set_joint(s.sim, self.slide_qpos, slide, mask)

    def drawer_link_pos(self, s: TaskState) -> torch.Tensor:
        return s.sim.xpos[:, self.drawer_body]

    def handle_point(self, s: TaskState, handle_offset: tuple[float, float, float]) -> torch.Tensor:
        """The observed handle point: ``drawer_link`` + ``handle_offset``."""
        return offset(self.drawer_link_pos(s), *handle_offset)
