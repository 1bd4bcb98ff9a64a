"""Pieces shared by door_open and door_close (Meta-World ``sawyer_door_pull.xml``, the ``doorlockB`` safe).

The safe (body ``door``) is world-fixed and placed per world; its door (``door_link``) turns on the vertical hinge
``doorjoint`` (range [-2, 0] rad, closed at 0, opening towards the robot) at ``safe + (-0.185, -0.1, 0)``. MTBench
observes its ``handle`` body, ``door_link + (0.325, -0.062, 0)`` in the door's frame (the origin of the handle mesh,
where MTBench's asset puts a body; Meta-World observes the mesh's centre instead): :func:`edit_door_scene` marks it
with the site ``handle_point``. The door turns on its hinge alone (no contacts with the safe or the retaining wall,
stiff limit).

This private module (task discovery ignores modules whose name starts with ``_``) holds only the scene constants,
the edit and the door coordinates (x along the panel from the hinge, y across it: negative on the handle's outer
side) of the points where the Panda works the door (door_open's scripted controller and v2 reward); each task file
states its own reward.
"""

from __future__ import annotations

import mujoco
import torch

from ..scene import guide_by_joint

SAFE_BODY = "door"
DOOR_BODY = "door_link"
DOOR_JOINT = "doorjoint"
HANDLE_SITE = "handle_point"
HANDLE_ON_DOOR = (0.325, -0.062, 0.0)  # MTBench's ``handle`` body in the door frame
# door_open, pulling: the open gripper's far (+y) finger centre at HOOK, 1.35 cm behind the bar (back face at y
# -0.097) with the palm, which reaches 10 cm beyond the TCP along y, 1.5 cm in front of the panel (outer face at
# -0.01); the TCP is HOOK_TCP_Y towards the robot (world -y) of that finger (open gripper: finger centre to TCP)
HOOK = (0.40, -0.071)
HOOK_TCP_Y = 0.054
# door_open, pushing: the TCP at PUSH on the panel's inner side (inner face at y = +0.01), PUSH_Z above the table:
# the fingertips overlap the panel's top by 3 cm, the palm (from TCP + 3.7 cm) stays above it (0.273)
PUSH = (0.33, 0.055)
PUSH_Z = 0.25


def door_point(hinge: torch.Tensor, theta: torch.Tensor, p: tuple[float, float]) -> torch.Tensor:
    """World x-y ``[..., 2]`` of the door-coordinates point ``p`` with the door at hinge angle ``theta`` (the
    ``doorjoint`` position: 0 closed, negative open) about the hinge's x-y ``hinge[..., :2]``."""
    c, s = torch.cos(theta), torch.sin(theta)
    return hinge[..., :2] + torch.stack([p[0] * c - p[1] * s, p[0] * s + p[1] * c], dim=-1)


def hook_tcp(hinge: torch.Tensor, theta: torch.Tensor) -> torch.Tensor:
    """World x-y ``[..., 2]`` of the TCP whose open gripper hooks the bar (far finger at :data:`HOOK`) with the door
    at hinge angle ``theta``."""
    finger = door_point(hinge, theta, HOOK)
    return torch.stack([finger[..., 0], finger[..., 1] - HOOK_TCP_Y], dim=-1)


def edit_door_scene(spec: mujoco.MjSpec) -> None:
    """The door turns on its hinge alone; the site ``handle_point`` marks MTBench's handle point."""
    guide_by_joint(spec, DOOR_BODY, DOOR_JOINT, ("doorlockB", "RetainingWall"))
    spec.body(DOOR_BODY).add_site(name=HANDLE_SITE, pos=list(HANDLE_ON_DOOR), size=[0.005, 0.005, 0.005], group=4)
