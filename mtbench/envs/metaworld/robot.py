"""The Franka Panda (MuJoCo Menagerie) as the Meta-World manipulator, driven by a mocap weld.

Controller choice: like Meta-World (and unlike the original MTBench, which ran damped-least-squares IK into
joint position targets), the hand is welded to a mocap body. An action moves the mocap target by
``action[:3] * ACTION_SCALE`` metres per control step (clipped to the task's hand workspace) with the hand
orientation held pointing down; the arm joints are passive (gravity-compensated, damped) and follow the weld.
Why: the weld gives every task the same well-conditioned Cartesian response at any arm configuration (no IK
singularities or joint-limit clamping inside the control loop), needs no per-step Jacobian solve in torch, and
keeps the physics of contacts between the hand and objects intact (the weld is a soft constraint solved with the
contacts). The gripper is a force actuator on the finger tendon: ``action[3] = +1`` closes the fingers with
``GRIPPER_FORCE`` newtons, ``-1`` opens them. This is Meta-World's convention, so the caging reward's
``clip(action[3], 0, 1)`` "gripper closed" term and the physics agree (the original MTBench had them inverted).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ...assets import menagerie_dir

ACTION_SCALE = 0.01  # metres of end-effector displacement per control step at |action| = 1
GRIPPER_FORCE = 60.0  # newtons on the finger tendon at |action[3]| = 1
FINGER_DAMPING = 60.0  # N s / m on each finger slide joint
PREFIX = "panda/"
HAND = PREFIX + "hand"
LEFT_PAD = PREFIX + "leftpad"
RIGHT_PAD = PREFIX + "rightpad"
# Hand pointing down (hand z -> world -z) with the fingers opening along world y, as Meta-World's pads do.
HAND_DOWN_QUAT = np.array([0.0, 0.0, 1.0, 0.0])
# TCP (midpoint of the finger pads) relative to the hand frame origin, along the hand z axis.
TCP_OFFSET = 0.1034
ARM_JOINTS = tuple(f"{PREFIX}joint{i}" for i in range(1, 8))
FINGER_JOINTS = (PREFIX + "finger_joint1", PREFIX + "finger_joint2")
# A comfortable elbow-up configuration used as the starting point when solving the initial arm pose.
READY_QPOS = np.array([0.0, 0.3, 0.0, -2.2, 0.0, 2.5, 0.785, 0.04, 0.04])
# Collision filtering: robot geoms collide with the world/objects (conaffinity 1) but not with each other.
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 1, 0
# Collision geometry of the hand and fingers: "primitive" (boxes, default) or "mesh" (Menagerie's convex meshes).
ROBOT_COLLISIONS = ("primitive", "mesh")
# Boxes fitted to the convex hulls of Menagerie's ``hand_c`` and ``finger_0`` meshes, in the body frames (hand: z
# towards the fingers, y the opening axis; finger: y away from the other finger, z towards the tip). Boxes are
# cheap for MuJoCo Warp's convex collision (constant-time support function; box-box and box-plane are primitive
# colliders), where the meshes' hulls (102 and 49 vertices) made GJK/EPA the bulk of a contact-rich step.
# name -> (pos, half sizes, rotation about the body x axis in radians)
HAND_BOXES = {"hand_box": ((0.0, 0.0, 0.029), (0.025, 0.102, 0.037), 0.0)}
FINGER_BOXES = {
    # pad and tip in one box: the pad's grasping face (y = 1.5 mm) is Menagerie's fingertip pad
    "tip_box": ((0.0, 0.008, 0.045), (0.0088, 0.0065, 0.009), 0.0),
    # the slanted middle section, from the base (y 11.6..25.3 mm at z 19 mm) to the tip (y 9.5..14.4 mm at z 50 mm)
    "taper_box": ((0.0, 0.01525, 0.0343), (0.0095, 0.005, 0.0165), 0.204),
    "base_box": ((0.0, 0.01865, 0.00965), (0.0105, 0.00765, 0.00965), 0.0),
}


def panda_spec(collision: str = "primitive") -> mujoco.MjSpec:
    """Menagerie Panda prepared for mocap control: no arm actuators, gravity compensation, pad sites,
    a tendon force actuator for the gripper and no robot self-collisions.

    Args:
        collision: hand and finger collision geometry, one of ``ROBOT_COLLISIONS``: ``"primitive"`` (boxes fitted
            to Menagerie's collision meshes; see ``HAND_BOXES``/``FINGER_BOXES``) or ``"mesh"`` (Menagerie's
            convex meshes and fingertip pad boxes). The arm links keep their meshes either way.
    """
    if collision not in ROBOT_COLLISIONS:
        raise ValueError(f"unknown robot collision {collision!r}; valid choices: {', '.join(ROBOT_COLLISIONS)}")
    spec = mujoco.MjSpec.from_file(str(menagerie_dir("franka_emika_panda") / "panda.xml"))
    if collision == "primitive":
        _use_primitive_hand_collision(spec)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER  # implicitfast is not supported by MuJoCo Warp
    for act in list(spec.actuators):
        spec.delete(act)
    for light in list(spec.lights):
        spec.delete(light)
    for key in list(spec.keys):
        spec.delete(key)
    for body in spec.bodies:
        if body.name:
            body.gravcomp = 1.0
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.contype = ROBOT_CONTYPE
            geom.conaffinity = ROBOT_CONAFFINITY
            geom.condim = 4 if "finger" in (geom.parent.name or "") else geom.condim
            if "finger" in (geom.parent.name or ""):
                geom.friction = [2.0, 0.1, 0.002]
    for name in ("left_finger", "right_finger"):
        finger = spec.body(name)
        finger.add_site(name="leftpad" if name == "left_finger" else "rightpad", pos=[0.0, 0.0055, 0.0445],
                        size=[0.005, 0.005, 0.005], rgba=[0, 1, 0, 0.3], group=4)
    spec.body("hand").add_site(name="tcp", pos=[0.0, 0.0, TCP_OFFSET], size=[0.005, 0.005, 0.005], group=4)
    # joint damping keeps the passive arm well behaved while the weld drags it; the fingers are damped so that
    # the gripper closes in ~5 control steps (at 0.5 m/s): with Menagerie's damping of 1 the 4 mm pads move
    # ~1 cm per 4 ms physics step under full force and tunnel through thin objects
    for j in spec.joints:
        if j.type == mujoco.mjtJoint.mjJNT_HINGE:
            j.damping = [10.0, 0.0, 0.0]
            j.armature = 0.1
        elif j.name in ("finger_joint1", "finger_joint2"):
            j.damping = [FINGER_DAMPING, 0.0, 0.0]
    # Mesh collision: the four small ridge boxes on each fingertip (half sizes < 5 mm) make contact normals along
    # the pad plane that wedge objects sideways; the main pad box and the finger mesh carry the grasp.
    for geom in spec.geoms:
        if (geom.type == mujoco.mjtGeom.mjGEOM_BOX and "finger" in (geom.parent.name or "")
                and max(geom.size) < 0.005):
            geom.contype = 0
            geom.conaffinity = 0
    spec.add_actuator(
        name="gripper",
        target="split",
        trntype=mujoco.mjtTrn.mjTRN_TENDON,
        gaintype=mujoco.mjtGain.mjGAIN_FIXED,
        gainprm=[GRIPPER_FORCE] + [0.0] * 9,
        biastype=mujoco.mjtBias.mjBIAS_NONE,
        ctrlrange=[-1.0, 1.0],
        ctrllimited=True,
    )
    return spec


def _use_primitive_hand_collision(spec: mujoco.MjSpec) -> None:
    """Replace the colliding geoms of the hand and both fingers by ``HAND_BOXES`` and ``FINGER_BOXES``."""
    for body_name, boxes in (("hand", HAND_BOXES), ("left_finger", FINGER_BOXES), ("right_finger", FINGER_BOXES)):
        body = spec.body(body_name)
        for geom in list(body.geoms):
            if geom.contype or geom.conaffinity:
                spec.delete(geom)
        for name, (pos, size, angle) in boxes.items():
            body.add_geom(name=f"{body_name}_{name}", type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(pos), size=list(size),
                          quat=[np.cos(angle / 2), np.sin(angle / 2), 0.0, 0.0], group=3, rgba=[0.5, 0.5, 0.5, 0.3],
                          contype=ROBOT_CONTYPE, conaffinity=ROBOT_CONAFFINITY)
