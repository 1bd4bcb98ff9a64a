"""Pieces shared by coffee_button, coffee_pull and coffee_push (Meta-World ``sawyer_coffee.xml``).

The scene: a coffee machine (body ``coffee_machine``, world-fixed, placed per world with ``set_body_pos``; origin on
the table under its centre) with a slide-jointed button (body ``cmbutton``, joint ``goal_slidey``, range [0, 0.03]
along +y: pressed = pushed 3 cm into the machine). The button is a cylinder of radius 3.2 cm whose front face
centre is Meta-World's site ``buttonStart`` = ``cmbutton + (0, -0.22, 0.3)`` (MTBench's observed ``buttonStart``
body). The machine's upper part (0.23 .. 0.37 above the table) spans ``y = -0.098 .. 0.098`` and a frame of boxes
around the button reaches forward to ``y = -0.183``; the spout (a vertical cylinder, radius 1.6 cm, 0.111 .. 0.193
above the table) is at ``y = -0.141``.

A free mug (body ``obj``; its collision cylinder has radius 2.8 cm and height 6.6 cm, centred 3.5 cm above the
body origin). MTBench's mug asset has its origin at that centre and MTBench observes it, so
:func:`edit_coffee_scene` adds the site ``mug_center`` there and the tasks report it. MTBench spawns the mug turned
by 90 degrees about its z axis (handle towards MTBench's +y, i.e. towards world -x); Meta-World's unturned mug has
its handle at +x, so the tasks place it turned by 180 degrees (quaternion (0, 0, 0, 1)).

This private module (task discovery ignores modules whose name starts with ``_``) holds the scene edits, the
placement helpers and the observation of the three task files; each task file states its own reward.
"""

from __future__ import annotations

import mujoco
import torch

from ..scene import SceneSpec, guide_by_joint
from ..task import TaskState, offset

# Meta-World's hand_init_pos of the three coffee tasks
SCENE = SceneSpec("sawyer_coffee.xml", hand_init_pos=(0.0, 0.4, 0.2))
MACHINE_BODY = "coffee_machine"
BUTTON_BODY = "cmbutton"
BUTTON_JOINT = "goal_slidey"
BUTTON_SITE = "buttonStart"
MUG_BODY = "obj"
MUG_JOINT = "objjoint"  # Meta-World's free joint has no name; edit_coffee_scene names it
MUG_SITE = "mug_center"
MUG_CENTER_HEIGHT = 0.035  # collision cylinder centre above the mug body origin (its bottom)
BUTTON_FROM_MACHINE = (0.0, -0.22, 0.3)  # buttonStart relative to the machine, button unpressed
BUTTON_TRAVEL = 0.03
# MTBench places the machine 0.3 m behind (+y) the mug's initial position in coffee_pull and coffee_push
# (``obj_init_pos + (.3, 0, 0)`` in its frame; Meta-World v3: 0.22 behind the mug (pull) or the goal (push)).
MACHINE_BEHIND_MUG = 0.3


def edit_coffee_scene(spec: mujoco.MjSpec) -> None:
    """The button slides on its joint alone (no contacts with the machine's frame; stiff limit), the mug's free
    joint is named ``objjoint`` and the site ``mug_center`` marks MTBench's mug point."""
    guide_by_joint(spec, BUTTON_BODY, BUTTON_JOINT, ("cm_link",))
    (free,) = [j for j in spec.joints if j.parent.name == MUG_BODY]
    free.name = MUG_JOINT
    spec.body("mug").add_site(name=MUG_SITE, pos=[0.0, 0.0, MUG_CENTER_HEIGHT], size=[0.005, 0.005, 0.005],
                              group=4)


class CoffeeSceneMixin:
    """Model ids and reset writes of the coffee scene; mix into a ``MetaWorldTask`` subclass (listed first)."""

    def bind(self, model) -> None:
        self.machine_body = self.body_id(MACHINE_BODY)
        self.button_body = self.body_id(BUTTON_BODY)
        self.button_qpos = self.joint_qposadr(BUTTON_JOINT)
        self.button_site = self.site_id(BUTTON_SITE)
        self.mug_body = self.body_id(MUG_BODY)
        self.mug_qpos = self.joint_qposadr(MUG_JOINT)
        self.mug_site = self.site_id(MUG_SITE)
        self._mug_quat = self.const([0.0, 0.0, 0.0, 1.0])  # turned by 180 degrees about z: handle towards -x

    def place_machine(self, s: TaskState, machine: torch.Tensor, mask: torch.Tensor) -> None:
        """Machine at ``machine`` ([n, 3]) with its button released, in the worlds of ``mask``."""
        self.set_body_pos(s.sim, self.machine_body, machine, mask)
        self.set_joint(s.sim, self.button_qpos, 0.0, mask)

    def place_mug(self, s: TaskState, mug: torch.Tensor, mask: torch.Tensor) -> None:
        """Mug body (its bottom centre) at ``mug`` ([n, 3]), handle towards -x, at rest."""
        self.set_free_body(s.sim, self.mug_qpos, mug, mask, quat=self._mug_quat.expand(mug.shape[0], 4))

    def button_pose(self, s: TaskState) -> tuple[torch.Tensor, torch.Tensor]:
        """MTBench's ``buttonStart`` point (the button's front face centre) and the button's orientation."""
        return s.sim.site_xpos[:, self.button_site], s.sim.xquat[:, self.button_body]

    def mug_pose(self, s: TaskState) -> tuple[torch.Tensor, torch.Tensor]:
        """MTBench's mug point (the centre of its collision cylinder) and the mug's orientation."""
        return s.sim.site_xpos[:, self.mug_site], s.sim.xquat[:, self.mug_body]


def place_mug_task(task, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
    """Reset of coffee_pull / coffee_push from ``vec = (mug xyz, goal xyz)``: mug at the sampled point (table
    height), the machine ``MACHINE_BEHIND_MUG`` behind it with the button released, goal at the sampled point;
    ``obj_init_pos`` = the sampled mug point (MTBench's ``obj_init_pos``)."""
    mug = vec[:, :3]
    task.place_mug(s, mug, mask)
    task.place_machine(s, offset(mug, 0.0, MACHINE_BEHIND_MUG, 0.0), mask)
    task.masked_set(s.obj_init_pos, mug, mask)
    task.masked_set(s.goal, vec[:, 3:6], mask)

