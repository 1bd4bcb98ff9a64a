"""Pieces shared by handle_press, handle_press_side, handle_pull and handle_pull_side (Meta-World
``sawyer_handle_press.xml`` / ``sawyer_handle_press_sideways.xml``).

The scene: a fixed housing body ``box`` placed per world (batched ``body_pos``) with the lever ``handle_link`` on a
vertical slide joint (unnamed in the XML; named ``HANDLE_JOINT`` here), range [-0.1, 0] (0 = up), damping 30. The
red grip is a horizontal cylinder (radius 2.2 cm, half-length 7 cm, along the housing's x axis) at
``handle_link + (0, -0.166, 0)``. Sites used by the tasks, in the housing frame with the slide at ``q``:

* ``handleStart`` = ``(0, -0.216, 0.172 + q)``: the observed handle point (MTBench observes the body of the same
  name, at the same place in its asset);
* ``goalPress`` = ``(0, -0.216, 0.075)``: the press target (MTBench: initial handle point - (0, 0, 0.172 - 0.075));
* ``goalPull`` = ``(0, -0.216, 0.172)``: the pull target (MTBench: the handle point pressed down, + (0, 0, 0.1)),
  i.e. ``handleStart`` at ``q = 0``.

Front tasks (``sawyer_handle_press.xml``): the housing is unrotated, the lever points to -y (towards the robot).
Side tasks (``sawyer_handle_press_sideways.xml``): the housing is turned by +90 degrees about z (Meta-World's
``euler="0 0 1.57"``), the lever points to +x. MTBench's assets are placed the same way once its frame is mapped
to ours (``x_mw = -y_mtb``, ``y_mw = x_mtb + 0.6``; its front asset carries a -90 degree turn, its side asset none).

Reset vectors hold the housing position only (MTBench's goal part is unused: the targets follow from the housing).
The handle is guided by its slide joint alone (its parent housing never collides with it; the limit is made stiff,
see ``scene.guide_by_joint``), and its slide gets an armature so that finger contacts on the 2 g handle are as
stiff as on other objects (``HANDLE_ARMATURE``).
"""

from __future__ import annotations

import mujoco
import torch

from ..robot import FINGER_JOINTS
from ..scene import SceneSpec, guide_by_joint
from ..task import Objects, TaskState

FRONT_SCENE = SceneSpec("sawyer_handle_press.xml", hand_init_pos=(0.0, 0.6, 0.2))
SIDE_SCENE = SceneSpec("sawyer_handle_press_sideways.xml", hand_init_pos=(0.0, 0.6, 0.2))
# housing position x, y, z (MTBench obj_low/obj_high mapped to our frame; equal to Meta-World v3's ranges)
FRONT_RESET_LOW = (-0.1, 0.8, 0.0)
FRONT_RESET_HIGH = (0.1, 0.9, 0.0)
SIDE_RESET_LOW = (-0.35, 0.65, 0.0)
SIDE_RESET_HIGH = (-0.25, 0.75, 0.0)
HANDLE_BODY = "handle_link"
HOUSING_BODY = "box"
HANDLE_JOINT = "handle_slide"
HANDLE_SITE = "handleStart"
PRESS_SITE = "goalPress"
PULL_SITE = "goalPull"
SLIDE_LOW, SLIDE_HIGH = -0.1, 0.0  # slide range (MTBench resets press tasks to the upper, pull tasks to the lower)
# The handle weighs 2 g: MuJoCo scales a contact's softness with the inverse weights of the bodies involved, so the
# fingers sank 9 mm into the grip and slid off it (tested in MuJoCo C). An armature on the slide joint (as the button
# of button_press_topdown has) makes the grip as stiff as other objects: 0.6 mm under the full grip force.
HANDLE_ARMATURE = 0.5
# MTBench's gripper openness from the finger joints, (q1 + q2) / 0.08
FINGER_TRAVEL = 0.08


class HandleSceneMixin:
    """Model ids and reset writes of the handle scenes; mix into a ``MetaWorldTask`` subclass (listed first)."""

    SLIDE_RESET: float  # slide position at reset (press: up, pull: down)
    GOAL_SITE: str  # PRESS_SITE or PULL_SITE

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Name the handle's slide joint, give it an armature (``HANDLE_ARMATURE``) and let it alone guide the
        handle (stiff limit)."""
        joints = spec.body(HANDLE_BODY).joints
        if len(joints) != 1:
            raise RuntimeError(f"expected one joint on {HANDLE_BODY!r}, found {len(joints)}")
        joints[0].name = HANDLE_JOINT
        guide_by_joint(spec, HANDLE_BODY, HANDLE_JOINT, ("hdlprs",))
        joints[0].armature = HANDLE_ARMATURE

    def bind(self, model) -> None:
        self.housing_body = self.body_id(HOUSING_BODY)
        self.handle_body = self.body_id(HANDLE_BODY)
        self.slide_qpos = self.joint_qposadr(HANDLE_JOINT)
        self.handle_site = self.site_id(HANDLE_SITE)
        self.press_site = self.site_id(PRESS_SITE)
        self.pull_site = self.site_id(PULL_SITE)
        self.goal_site = self.site_id(self.GOAL_SITE)
        self.finger_qpos = tuple(self.joint_qposadr(n) for n in FINGER_JOINTS)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        """Move the housing to ``vec[:, :3]`` and set the slide to ``SLIDE_RESET`` in the worlds of ``mask``."""
        self.set_body_pos(s.sim, self.housing_body, vec[:, :3], mask)
        self.set_joint(s.sim, self.slide_qpos, self.SLIDE_RESET, mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        # MTBench: obj_init_pos = the handle point at reset, target = the goal site's point (both measured here)
        self.masked_set(s.obj_init_pos, s.obj_pos, mask)
        self.masked_set(s.goal, s.sim.site_xpos[:, self.goal_site], mask)

    def objects(self, s: TaskState) -> Objects:
        """The ``handleStart`` point with the handle's orientation (MTBench's ``handleStart`` body)."""
        return Objects(s.sim.site_xpos[:, self.handle_site], s.sim.xquat[:, self.handle_body])

    def finger_opening(self, s: TaskState) -> torch.Tensor:
        """MTBench's ``tcp_opened = (q_finger1 + q_finger2) / 0.08`` from the Panda's finger joints ``[n]``."""
        q = s.sim.qpos
        return (q[:, self.finger_qpos[0]] + q[:, self.finger_qpos[1]]) / FINGER_TRAVEL
