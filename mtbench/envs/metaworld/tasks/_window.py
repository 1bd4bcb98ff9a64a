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

from typing import Literal

import mujoco
import torch

from ..reward_utils import hamacher_product, tolerance
from ..scene import SceneSpec, guide_by_joint
from ..task import Objects, TaskState

# Meta-World's init_config hand_init_pos of both window tasks
SCENE = SceneSpec("sawyer_window_horizontal.xml", hand_init_pos=(0.0, 0.4, 0.2))
SLIDE_JOINT = "window_slide"
WINDOW_BODY = "window"
SLIDE_TRAVEL = 0.2
TARGET_RADIUS = 0.05  # Meta-World's TARGET_RADIUS (in_place bound on the x error)
HANDLE_RADIUS = 0.02  # Meta-World's handle_radius (reach bound)
SUCCESS_RADIUS = 0.01  # paper-era MTBench ("changed from .05")



class WindowSceneMixin:
    """Model ids, reset writes and the handle-at-reset buffer of the window scene; mix into a ``MetaWorldTask``
    subclass (listed first) that sets ``handle_site_name``."""

    handle_site_name: str
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
        # the handle point at the start of the episode (kinematics are fresh here)
        self.masked_set(s.buffers["handle_init"], s.obj_pos, mask)


def window_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, handle_init: torch.Tensor,
                  init_tcp: torch.Tensor, x_error_init: torch.Tensor | float,
                  reach_sigmoid: Literal["long_tail", "gaussian"]
                  ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Meta-World v2 window reward ``10 · H(reach, in_place)`` (H = Hamacher product).

    ``in_place = tol(|handle_x − goal_x|, (0, .05), margin |x_error_init − .05|, long_tail)`` and ``reach =
    tol(‖handle − tcp‖, (0, .02), margin |‖handle_init − tcp_init‖ − .02|, reach_sigmoid)``; window-open uses
    ``x_error_init = |window_x − goal_x| = 0.2`` and a long-tail reach, window-close ``|handle_init_x − goal_x| =
    0.21`` and a Gaussian reach. Returns ``(reward, reach, in_place)``.
    """
    x_error = (handle[..., 0] - goal[..., 0]).abs()
    in_place = tolerance(x_error, bounds=(0.0, TARGET_RADIUS), margin=_abs(x_error_init - TARGET_RADIUS),
                         sigmoid="long_tail")
    tcp_to_obj = (handle - tcp).norm(dim=-1)
    tcp_to_obj_init = (handle_init - init_tcp).norm(dim=-1)
    reach = tolerance(tcp_to_obj, bounds=(0.0, HANDLE_RADIUS), margin=(tcp_to_obj_init - HANDLE_RADIUS).abs(),
                      sigmoid=reach_sigmoid)
    return 10.0 * hamacher_product(reach, in_place), reach, in_place


def window_success(handle: torch.Tensor, handle_init: torch.Tensor, direction: float) -> torch.Tensor:
    """MTBench: ``‖handle − (handle_init + direction · 0.2 x̂)‖ ≤ 0.01`` (the sash slid through its full travel)."""
    target = torch.stack([handle_init[..., 0] + direction * SLIDE_TRAVEL, handle_init[..., 1],
                          handle_init[..., 2]], dim=-1)
    return (handle - target).norm(dim=-1) <= SUCCESS_RADIUS


def _abs(x: torch.Tensor | float) -> torch.Tensor | float:
    return x.abs() if isinstance(x, torch.Tensor) else abs(x)
