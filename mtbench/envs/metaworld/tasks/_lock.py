"""Pieces shared by door_lock and door_unlock (Meta-World ``sawyer_door_lock.xml``, the ``doorlockA`` safe).

The scene: a safe (body ``door``, world-fixed, placed per world with ``set_body_pos``) whose door (``door_link``,
at ``door + (-0.185, -0.1, 0)``) has no hinge in this asset: it is fixed. The lock lever (``lock_link``, at
``door + (0, -0.118, 0.061)``) turns on an unnamed hinge about +y (range [0, 1.57]; named ``lock_joint`` by
:func:`edit_lock_scene`): at 0 the lever points horizontally to +x (unlocked), at 1.57 straight down (locked). The
lever is a 10 x 3.8 x 2 cm box from the hinge outwards, 12.3 to 16.1 cm in front of the safe's origin, i.e. 1.3 cm
in front of the door's face (``door - 0.11``). Meta-World's sites ``lockStartLock`` and ``lockStartUnlock`` (lever
frame ``(0.09, -0.04, ±0.01)``) are MTBench's observed bodies of the same names (body ids +3 / +4 of its asset).

This asset is ``doorlockA``; door_open/door_close use ``doorlockB`` (hinged door, no lock). Nothing is shared
with them: every per-world quantity lives in the task state, so the joint limits of one task cannot leak into
another (the original MT50 let assets of one type overwrite each other's limits).
"""

from __future__ import annotations

import mujoco
import torch

from ..scene import SceneSpec, guide_by_joint
from ..task import Objects, TaskState, offset

# Meta-World's hand_init_pos of door-lock/door-unlock is (0, 0.6, 0.2); there the Panda's palm (20 cm long along y,
# 3.7 cm above the TCP) overlaps the lock's base and its open fingers overlap the lever for the nearer safe
# positions, so the hand starts 10 cm higher.
SCENE = SceneSpec("sawyer_door_lock.xml", hand_init_pos=(0.0, 0.6, 0.3))
SAFE_BODY = "door"
LOCK_BODY = "lock_link"
LOCK_JOINT = "lock_joint"
LOCK_FROM_SAFE = (0.0, -0.118, 0.061)  # MTBench: obj_init_pos = root + (-.118, 0, .061) in its frame
LOCKED = 1.57  # the joint's upper limit (MTBench resets door_unlock there, door_lock at the lower limit 0)
LOCK_LENGTH = 0.1  # MTBench's LOCK_LENGTH: margin of the lock_pressed / pushed terms
# The 1 g lever's joint limits are mass-scaled soft constraints: with Meta-World's armature (0.001) a hand shoving
# it (20 N m) pushes it 0.12 rad past its limit even with the stiff limit; 0.01 keeps it within 2 mrad.
LOCK_ARMATURE = 0.01
# reset: safe at x ~ U[-0.1, 0.1], y ~ U[0.8, 0.85], z = 0.15 (MTBench (.20, -.1) .. (.25, .1) at table + .3/2,
# mapped x = -y_mtb, y = x_mtb + 0.6, z = z_mtb - 1.027; the same as Meta-World v3)
RESET_LOW = (-0.1, 0.8, 0.15)
RESET_HIGH = (0.1, 0.85, 0.15)


def edit_lock_scene(spec: mujoco.MjSpec) -> None:
    """Name the lever's hinge ``lock_joint``; the lever turns on it alone (no contacts with the door or the safe,
    stiff limits, armature ``LOCK_ARMATURE``)."""
    (hinge,) = [j for j in spec.joints if j.parent.name == LOCK_BODY]
    hinge.name = LOCK_JOINT
    guide_by_joint(spec, LOCK_BODY, LOCK_JOINT, ("door_link", "doorlockA"))
    hinge.armature = LOCK_ARMATURE


class LockSceneMixin:
    """Model ids, reset writes and observation of the lock scene; mix into a ``MetaWorldTask`` subclass (listed
    first) that sets ``LOCK_SITE`` (the observed site) and ``LOCK_START`` (the lever's joint angle at reset)."""

    LOCK_SITE: str
    LOCK_START: float

    def bind(self, model) -> None:
        self.safe_body = self.body_id(SAFE_BODY)
        self.lock_body = self.body_id(LOCK_BODY)
        self.lock_qpos = self.joint_qposadr(LOCK_JOINT)
        self.lock_site = self.site_id(self.LOCK_SITE)

    def place_safe(self, s: TaskState, safe: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """Safe at ``safe`` ([n, 3]), the lever at ``LOCK_START``; ``obj_init_pos`` = the lever's hinge (MTBench's
        ``obj_init_pos``, "the lock link pos"), which is returned."""
        self.set_body_pos(s.sim, self.safe_body, safe, mask)
        self.set_joint(s.sim, self.lock_qpos, self.LOCK_START, mask)
        hinge = offset(safe, *LOCK_FROM_SAFE)
        self.masked_set(s.obj_init_pos, hinge, mask)
        return hinge

    def objects(self, s: TaskState) -> Objects:
        """The observed lever point and the lever's orientation (MTBench reports the rigid body of the site's
        name, which turns with the lever)."""
        return Objects(s.sim.site_xpos[:, self.lock_site], s.sim.xquat[:, self.lock_body])
