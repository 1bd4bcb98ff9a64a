"""Pieces shared by window_open and window_close (Meta-World ``sawyer_window_horizontal.xml``).

The scene: a window frame body ``window`` placed per world (its ``body_pos`` is batched) with a sliding sash
``windowb_a`` (joint ``window_slide``, axis +x, range [0, 0.2]: 0 = closed, 0.2 = open). The sash's handle is a
vertical bar (capsule, radius 8 mm, z within ±0.053 of the window origin) at ``window + (-0.014 + q, -0.095, 0)``
held by two horizontal arms at z = ±0.045 that reach back to the sash. Meta-World observes the handle through
the sites ``handleOpenStart`` (``window + (-0.04 + q, -0.095, 0)``, left of the bar) for window-open and
``handleCloseStart`` (``window + (0.01 + q, -0.095, 0)``, right of the bar) for window-close.

This private module (task discovery ignores modules whose name starts with ``_``) holds the scene's constants, a
mixin and the reward/success terms shared by the two window task files, which compose them with their own
parameters; the terms are pure torch so that the tests can evaluate them without physics.
"""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import hamacher_product, tolerance
from ..scene import SceneSpec, guide_by_joint
from ..task import Objects, TaskState, offset

# Meta-World's init_config hand_init_pos of both window tasks
SCENE = SceneSpec("sawyer_window_horizontal.xml", hand_init_pos=(0.0, 0.4, 0.2))
SLIDE_JOINT = "window_slide"
WINDOW_BODY = "window"
SLIDE_TRAVEL = 0.2
HANDLE_RADIUS = 0.02  # MTBench's and Meta-World's handle_radius (reach bound)
SUCCESS_RADIUS = 0.01  # paper-era MTBench TARGET_RADIUS ("changed from .05"): in_place bound and success



class WindowSceneMixin:
    """Model ids, reset writes and the handle-at-reset buffer of the window scene; mix into a ``MetaWorldTask``
    subclass (listed first) that sets ``handle_site_name``."""

    handle_site_name: str
    direction: float  # +1: the sash opens along +x; -1: it closes along -x
    buffers = {"handle_init": (3,)}  # the handle point at the start of the episode

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """The sash slides on its joint alone (no contacts with the frame, the fixed pane or the wall; stiff
        limit). The XML's frame body has no name; it is named ``window_frame`` here."""
        (frame,) = [b for b in spec.bodies if not b.name and b.parent is not None and b.parent.name == WINDOW_BODY]
        frame.name = "window_frame"
        guide_by_joint(spec, "windowb_a", SLIDE_JOINT, ("window_frame", "windowb_b", "RetainingWall"))

    def bind(self, model) -> None:
        self.slide_qpos = self.joint_qposadr(SLIDE_JOINT)
        self.window_body = self.body_id(WINDOW_BODY)
        self.handle_site = self.site_id(self.handle_site_name)

    def place_window(self, s: TaskState, window: torch.Tensor, slide: float, mask: torch.Tensor) -> None:
        """Move the window frame to ``window`` ([n, 3]) and set the sash slide to ``slide`` in ``mask``'s worlds."""
        self.set_body_pos(s.sim, self.window_body, window, mask)  # moves the frame's fixed geoms too
        self.set_joint(s.sim, self.slide_qpos, slide, mask)

    def objects(self, s: TaskState) -> Objects:
        """The handle point as object 1 (no orientation: zeros), as Meta-World's window tasks report it."""
        return Objects(s.sim.site_xpos[:, self.handle_site])

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        # the handle point at the start of the episode (kinematics are fresh here); the goal (MTBench's target) is
        # that point moved through the full travel along the task's direction
        self.masked_set(s.buffers["handle_init"], s.obj_pos, mask)
        self.masked_set(s.goal, offset(s.obj_pos, self.direction * SLIDE_TRAVEL, 0.0, 0.0), mask)


def window_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, handle_init: torch.Tensor,
                  init_tcp: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """MTBench's window reward (before its ``* 0.01``): ``(H(reach, in_place), reach, in_place)``.

    ``in_place = tol(‖handle − goal‖, (0, .01), margin |‖handle_init − goal‖ − .01|, long_tail)`` and ``reach =
    tol(‖handle − tcp‖, (0, .02), margin |‖handle_init − init_tcp‖ − .02|, gaussian)``; H is the Hamacher product.
    Both window tasks use it (the goal is the handle point at the end of the travel).
    """
    in_place = tolerance((handle - goal).norm(dim=-1), bounds=(0.0, SUCCESS_RADIUS),
                         margin=((handle_init - goal).norm(dim=-1) - SUCCESS_RADIUS).abs(), sigmoid="long_tail")
    reach = tolerance((handle - tcp).norm(dim=-1), bounds=(0.0, HANDLE_RADIUS),
                      margin=((handle_init - init_tcp).norm(dim=-1) - HANDLE_RADIUS).abs(), sigmoid="gaussian")
    return hamacher_product(reach, in_place), reach, in_place


def window_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle − goal‖ ≤ 0.01`` (the sash slid through its full travel)."""
    return (handle - goal).norm(dim=-1) <= SUCCESS_RADIUS
