"""Pieces shared by stick_push and stick_pull (Meta-World ``sawyer_stick_obj.xml``).

The scene: a stick (free body ``stick``, a box of square 4 cm section lying along x, 20 g; site ``stick_end`` at
its +x end) and a thermos (body ``object``, fixed to the world, whose child slides on the table along x and y on
the joints ``obj_slidex``/``obj_slidey``, range ±0.2; 3.3 kg, a cylinder of radius 6 cm and 28 cm height). The
thermos' handle is a rectangular loop on its -y side: two horizontal arms (z = 0.069 and 0.195) reach out to a
vertical bar 13.5 cm in front of its axis; the opening between the body (y = -0.06) and the bar (y = -0.13), which
a stick can pass through along x, is centred on the site ``insertion`` = thermos + (0, -0.09, 0.132).

MTBench's stick (``stick_l.xml``) is 20 cm long, Meta-World's 10 cm; ``edit_spec`` lengthens the stick to
MTBench's (collision box and visual mesh; the end site moves to +0.1). The rewards and success rules measure the
stick end against the thermos, and with the 10 cm stick the Panda cannot satisfy them: the stick end must reach
the thermos' axis while the TCP stays within 3 cm of the stick's centre, which puts the 20 cm long, 5 cm wide palm
into the thermos body (the Sawyer's hand is much smaller). The thermos is moved per world with ``set_body_pos``
(its slides start at 0).
"""

from __future__ import annotations

import mujoco
import torch

from ..scene import SceneSpec
from ..task import TaskState

SCENE = SceneSpec("sawyer_stick_obj.xml", hand_init_pos=(0.0, 0.6, 0.2))
STICK_HALF_LENGTH = 0.1  # MTBench's stick_l.xml (Meta-World: 0.05)
STICK_HALF = 0.02  # half of the stick's square section: a stick lying on the table has its centre at z = 0.02
INSERTION = (0.0, -0.09, 0.132)  # the ``insertion`` site relative to the thermos body


class StickSceneMixin:
    """Model ids, the 20 cm stick and the thermos placement; mix into a ``MetaWorldTask`` subclass (listed first)."""

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Lengthen the stick to MTBench's 20 cm (collision box, visual mesh and end site)."""
        (part,) = spec.body("stick").bodies
        box = next(g for g in part.geoms if g.name == "objGeom")
        scale = STICK_HALF_LENGTH / box.size[0]
        box.size = [STICK_HALF_LENGTH, box.size[1], box.size[2]]
        mesh = spec.mesh("stick")
        mesh.scale = [mesh.scale[0] * scale, mesh.scale[1], mesh.scale[2]]
        end = next(s for s in part.sites if s.name == "stick_end")
        end.pos = [STICK_HALF_LENGTH, 0.0, 0.0]

    def bind(self, model) -> None:
        self.stick_body = self.body_id("stick")
        self.stick_qpos = self.body_qposadr(self.stick_body)
        self.thermos_body = self.body_id("object")
        self.slide_x = self.joint_qposadr("obj_slidex")
        self.slide_y = self.joint_qposadr("obj_slidey")
        self.end_site = self.site_id("stick_end")
        self.insertion_site = self.site_id("insertion")

    def place(self, s: TaskState, stick: torch.Tensor, thermos: torch.Tensor, mask: torch.Tensor) -> None:
        """Put the stick at ``stick`` (unrotated) and the thermos body at ``thermos`` with its slides at 0."""
        self.set_free_body(s.sim, self.stick_qpos, stick, mask)
        self.set_body_pos(s.sim, self.thermos_body, thermos, mask)
        self.set_joint(s.sim, self.slide_x, 0.0, mask)
        self.set_joint(s.sim, self.slide_y, 0.0, mask)

    def stick_end(self, s: TaskState) -> torch.Tensor:
        return s.sim.site_xpos[:, self.end_site]

    def insertion(self, s: TaskState) -> torch.Tensor:
        return s.sim.site_xpos[:, self.insertion_site]
