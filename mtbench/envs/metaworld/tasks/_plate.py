"""Pieces shared by the plate-slide tasks (plate_slide, plate_slide_back, plate_slide_side, plate_slide_back_side;
Meta-World ``sawyer_plate_slide.xml`` / ``sawyer_plate_slide_sideway.xml``).

The scene: the plate (Meta-World's "puck": a 10 × 10 × 3 cm box, 50 g) hangs from the world-fixed body
``puck_channel`` at (0, 0.6, 0.015) on two slide joints, ``goal_slidex`` (axis x) and ``goal_slidey`` (axis y), so
it slides flat on the table without turning; the observed plate position is its geom centre
``(0 + q_x, 0.6 + q_y, 0.015)``. The goal cabinet (``puck_goal``, a hockey net: four posts and rails as capsules,
back, sides and roof as convex collision hulls) is world-fixed and moved per world with ``set_body_pos``; its
opening faces -y (``sawyer_plate_slide.xml``) or +x (``sawyer_plate_slide_sideway.xml``, turned by 90 degrees).

MTBench's plate was a free box (its slide joints commented out) and its cabinet an actor placed per reset; both
are the Meta-World assets, so positions map one to one (``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``).
To reach every MTBench target with the slide joints, their ranges are widened to ``x in [-0.3, 0.3]`` and
``y in [-0.1, 0.3]`` (Meta-World: [-0.2, 0.2] and [0, 0.3]: MTBench's plate_slide_side targets lie beyond both,
plate_slide_back_side's beyond the first). The plate does not collide with the table it rests on (its height is
fixed by the joints; the contact would only add four zero-depth contacts per world).

The rewards (MTBench, before its ``× 0.01``) share two tolerances, whose margins MTBench shortened by the
5 cm radius: :func:`plate_in_place` and :func:`plate_near`. Each task file composes its own reward.
"""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import tolerance
from ..scene import SceneSpec
from ..task import Objects, TaskState

SCENE = SceneSpec("sawyer_plate_slide.xml", hand_init_pos=(0.0, 0.6, 0.2))
SIDEWAY_SCENE = SceneSpec("sawyer_plate_slide_sideway.xml", hand_init_pos=(0.0, 0.6, 0.2))
CHANNEL = (0.0, 0.6, 0.015)  # puck_channel: the plate at zero slide
PLATE_Z = 0.015
PLATE_HALF = 0.05  # half size of the plate along x and y
SLIDE_X, SLIDE_Y = "goal_slidex", "goal_slidey"
SLIDE_X_RANGE = (-0.3, 0.3)
SLIDE_Y_RANGE = (-0.1, 0.3)
CABINET_BODY = "puck_goal"
PLATE_BODY = "plate"  # the channel's (unnamed) child body, named in ``edit_spec``
TARGET_RADIUS = 0.05
# MTBench's condition for the "at the plate" reward: TCP at most 5 cm above the table and within 7 cm of the point
NEAR_Z = 0.05
NEAR_RADIUS = 0.07


def plate_in_place(obj: torch.Tensor, goal: torch.Tensor, obj_init_pos: torch.Tensor) -> torch.Tensor:
    """``tolerance(‖obj − goal‖, (0, .05), margin=max(‖obj_init − goal‖ − .05, 0), long_tail)`` ``[n]``."""
    margin = ((obj_init_pos - goal).norm(dim=-1) - TARGET_RADIUS).clamp_min(0.0)
    return tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS), margin=margin, sigmoid="long_tail")


def plate_near(tcp: torch.Tensor, point: torch.Tensor, init_tcp: torch.Tensor,
               obj_init_pos: torch.Tensor) -> torch.Tensor:
    """``tolerance(‖tcp − point‖, (0, .05), margin=max(‖init_tcp − obj_init‖ − .05, 0), long_tail)`` ``[n]``
    (MTBench's ``object_grasped``; ``point`` is the plate or a point beside it)."""
    margin = ((init_tcp - obj_init_pos).norm(dim=-1) - TARGET_RADIUS).clamp_min(0.0)
    return tolerance((tcp - point).norm(dim=-1), bounds=(0.0, TARGET_RADIUS), margin=margin, sigmoid="long_tail")


class PlateSceneMixin:
    """Model edits, ids and reset writes of the plate scenes; mix into a ``MetaWorldTask`` subclass (listed
    first)."""

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Widen the plate's slide ranges (see the module docstring), name the plate body and keep it from
        colliding with the table below it."""
        for name, rng in ((SLIDE_X, SLIDE_X_RANGE), (SLIDE_Y, SLIDE_Y_RANGE)):
            spec.joint(name).range = list(rng)
        channel = spec.body("puck_channel")
        (plate,) = channel.bodies
        plate.name = PLATE_BODY
        spec.add_exclude(bodyname1=PLATE_BODY, bodyname2="tablelink")

    def bind(self, model) -> None:
        self.slide_x_qpos = self.joint_qposadr(SLIDE_X)
        self.slide_y_qpos = self.joint_qposadr(SLIDE_Y)
        self.plate_body = self.body_id(PLATE_BODY)
        self.cabinet_body = self.body_id(CABINET_BODY)

    def place_plate(self, s: TaskState, plate: torch.Tensor, cabinet: torch.Tensor, goal: torch.Tensor,
                    mask: torch.Tensor) -> None:
        """Slide the plate to ``plate`` (its centre, ``[n, 3]``), move the cabinet to ``cabinet`` and set the goal
        and ``obj_init_pos`` (= ``plate``) in the worlds of ``mask``."""
        self.set_joint(s.sim, self.slide_x_qpos, plate[:, 0] - CHANNEL[0], mask)
        self.set_joint(s.sim, self.slide_y_qpos, plate[:, 1] - CHANNEL[1], mask)
        self.set_body_pos(s.sim, self.cabinet_body, cabinet, mask)
        self.masked_set(s.obj_init_pos, plate, mask)
        self.masked_set(s.goal, goal, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.xpos[:, self.plate_body], s.sim.xquat[:, self.plate_body])
