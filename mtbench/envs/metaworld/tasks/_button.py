"""Pieces shared by the button tasks of MTBench ids 5-7 (button_press_topdown_wall, button_press, button_press_wall).

The scenes are Meta-World's ``sawyer_button_press*.xml``: a button box (body ``box``, world-fixed, placed per world
with ``set_body_pos``) with the slide-jointed ``button`` (joint ``btnbox_joint``, range [-0.06, 0] along the box's
local -y, so the button moves 6 cm into the box) and, in the ``*_wall`` scenes, a world-fixed ``wall`` (a 20 x 2 x
15 cm brick wall, long along world x). The box of ``button_press*`` faces the robot (button axis along world y);
the box of ``button_press_topdown*`` is turned by -90 degrees about x (button pointing up).

MTBench's observed button point is its ``buttonStart`` body, ``button + (0, -0.1935, 0)`` in the box frame: the
front face of the button cap (a cylinder of radius 4.3 cm spanning -0.194 .. -0.172 along the box's y axis).
:func:`edit_button_scene` adds the same point as the site ``button_start`` on Meta-World's ``button`` body (Meta-World
itself reads ``button + 0.193``), so it moves with the button.

This private module (task discovery ignores modules whose name starts with ``_``) holds the scene edits, the
placement and observation mixin, and the MTBench reward pieces the three task files compose.
"""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import hamacher_product, tolerance
from ..scene import guide_by_joint
from ..task import Objects, TaskState, offset

BUTTON_BODY = "button"
BUTTON_JOINT = "btnbox_joint"
BOX_BODY = "box"
WALL_BODY = "wall"
START_SITE = "button_start"
START_OFFSET = 0.1935  # MTBench: buttonStart = button + 0.1935 along the button's outward axis
TRAVEL = 0.06  # joint range of btnbox_joint; MTBench's target is the unpressed button point moved by the travel
WALL_HALF_HEIGHT = 0.075  # the wall's box geom is 15 cm tall, from the table up; MTBench observes its centre
# The 10 g button's joint limit is a mass-scaled soft constraint (see button_press_topdown.py): an armature on the
# slide plus a stiff limit keeps the pressed button within millimetres of its range when the hand shoves it.
BUTTON_ARMATURE = 0.5
# MTBench's button_press* success reward: the dense term plus 16 * button_pressed while the TCP is this close
SUCCESS_BONUS_WEIGHT = 16.0
SUCCESS_BONUS_RADIUS = 0.07


def edit_button_scene(spec: mujoco.MjSpec) -> None:
    """Button slide: guided by its joint alone (no contacts with its box or the retaining wall), stiff limit and
    armature; adds the site ``button_start`` at MTBench's ``buttonStart`` point on the button body."""
    guide_by_joint(spec, BUTTON_BODY, BUTTON_JOINT, ("buttonbox", "RetainingWall"))
    spec.joint(BUTTON_JOINT).armature = BUTTON_ARMATURE
    spec.body(BUTTON_BODY).add_site(name=START_SITE, pos=[0.0, -START_OFFSET, 0.0], size=[0.005, 0.005, 0.005],
                                    group=4)


class ButtonSceneMixin:
    """Model ids, placement and observation of the button scenes; mix into a ``MetaWorldTask`` subclass (listed
    first). Subclasses with a wall set ``WALL_OFFSET`` (wall body position relative to the box, x and y; the wall
    stands on the table)."""

    WALL_OFFSET: tuple[float, float] | None = None

    def bind(self, model) -> None:
        self.box_body = self.body_id(BOX_BODY)
        self.button_body = self.body_id(BUTTON_BODY)
        self.button_qpos = self.joint_qposadr(BUTTON_JOINT)
        self.start_site = self.site_id(START_SITE)
        self.wall_body = self.body_id(WALL_BODY) if self.WALL_OFFSET is not None else -1

    def place_box(self, s: TaskState, box: torch.Tensor, mask: torch.Tensor) -> None:
        """Box at ``box`` ([n, 3]), button unpressed, the wall (if any) at ``box + WALL_OFFSET`` on the table."""
        self.set_body_pos(s.sim, self.box_body, box, mask)
        self.set_joint(s.sim, self.button_qpos, 0.0, mask)
        if self.WALL_OFFSET is not None:
            wall = torch.stack([box[:, 0] + self.WALL_OFFSET[0], box[:, 1] + self.WALL_OFFSET[1],
                                torch.zeros_like(box[:, 2])], dim=-1)
            self.set_body_pos(s.sim, self.wall_body, wall, mask)

    def objects(self, s: TaskState) -> Objects:
        """Object 1: the button point and the button's orientation; object 2 (wall scenes): the wall's centre and
        orientation (MTBench reports its wall actor's pose, the centre of the wall box)."""
        button = s.sim.site_xpos[:, self.start_site]
        quat = s.sim.xquat[:, self.button_body]
        if self.WALL_OFFSET is None:
            return Objects(button, quat)
        wall = offset(s.sim.xpos[:, self.wall_body], 0.0, 0.0, WALL_HALF_HEIGHT)
        return Objects(button, quat, wall, s.sim.xquat[:, self.wall_body])


def button_terms(tcp_to_obj: torch.Tensor, near_margin: torch.Tensor, obj_to_target: torch.Tensor,
                 tcp_closed: torch.Tensor, near_bound: float) -> tuple[torch.Tensor, torch.Tensor]:
    """MTBench's button reward terms: ``(2 * H(tcp_closed, near_button), button_pressed)`` with
    ``near_button = tol(tcp_to_obj, (0, near_bound), margin=near_margin, long_tail)`` and
    ``button_pressed = tol(obj_to_target, (0, 0.005), margin=TRAVEL, long_tail)`` (MTBench's margin
    ``‖target − obj_init‖`` is the 6 cm travel by construction)."""
    near_button = tolerance(tcp_to_obj, bounds=(0.0, near_bound), margin=near_margin, sigmoid="long_tail")
    button_pressed = tolerance(obj_to_target, bounds=(0.0, 0.005), margin=TRAVEL, sigmoid="long_tail")
    return 2.0 * hamacher_product(tcp_closed, near_button), button_pressed


def button_success_reward(dense: torch.Tensor, button_pressed: torch.Tensor, tcp_to_obj: torch.Tensor,
                          dense_scale: float) -> torch.Tensor:
    """MTBench's reward on success steps of the button_press* tasks (not multiplied by ``reward_scale``): the
    scaled dense term plus ``16 * button_pressed`` while ``‖tcp − obj‖ < 0.07``."""
    bonus = torch.where(tcp_to_obj < SUCCESS_BONUS_RADIUS, SUCCESS_BONUS_WEIGHT * button_pressed,
                        torch.zeros_like(button_pressed))
    return dense_scale * dense + bonus
