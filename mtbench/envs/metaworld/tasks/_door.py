"""Pieces shared by door_open and door_close (Meta-World ``sawyer_door_pull.xml``, the ``doorlockB`` safe).

The safe (body ``door``) is world-fixed and placed per world; its door (``door_link``) turns on the vertical hinge
``doorjoint`` (range [-2, 0] rad, closed at 0, opening towards the robot) at ``safe + (-0.185, -0.1, 0)``. MTBench
observes its ``handle`` body, ``door_link + (0.325, -0.062, 0)`` in the door's frame (the origin of the handle mesh,
where MTBench's asset puts a body; Meta-World observes the mesh's centre instead): :func:`edit_door_scene` marks it
with the site ``handle_point``. The door turns on its hinge alone (no contacts with the safe or the retaining wall,
stiff limit).

This private module (task discovery ignores modules whose name starts with ``_``) holds only the scene constants
and edit; each task file states its own reward.
"""

from __future__ import annotations

import mujoco

from ..scene import guide_by_joint

SAFE_BODY = "door"
DOOR_BODY = "door_link"
DOOR_JOINT = "doorjoint"
HANDLE_SITE = "handle_point"
HANDLE_ON_DOOR = (0.325, -0.062, 0.0)  # MTBench's ``handle`` body in the door frame


def edit_door_scene(spec: mujoco.MjSpec) -> None:
    """The door turns on its hinge alone; the site ``handle_point`` marks MTBench's handle point."""
    guide_by_joint(spec, DOOR_BODY, DOOR_JOINT, ("doorlockB", "RetainingWall"))
    spec.body(DOOR_BODY).add_site(name=HANDLE_SITE, pos=list(HANDLE_ON_DOOR), size=[0.005, 0.005, 0.005], group=4)
