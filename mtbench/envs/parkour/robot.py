"""The Unitree Go1 (MuJoCo Menagerie) prepared for MTBench Parkour: PD joint control inside MuJoCo.

Control (MTBench ``final_go1_{easy,hard,hard_cl}.yaml``): the policy action ``a`` (12, clipped to
``±ACTION_CLIP``) sets joint targets ``q_target = a * ACTION_SCALE + DEFAULT_JOINT_POS``, and each joint gets
``tau = clip(ms0 * KP * (q_target - q) - ms1 * KD * qdot, ±TORQUE_LIMIT)`` at every 5 ms physics step, with
per-world, per-joint motor strengths ``ms0, ms1``. Here the PD law is a MuJoCo ``general`` actuator per joint:
``ctrl = q_target``, ``gainprm[0] = ms0 * KP``, ``biasprm[:3] = (0, -ms0 * KP, -ms1 * KD)`` and
``forcerange = ±TORQUE_LIMIT``, so the ``DECIMATION`` physics steps of one policy step run inside one MuJoCo Warp
graph with no torch work in between; the motor strengths are batched ``actuator_gainprm``/``actuator_biasprm``.

Joint order: Menagerie's order is already the original's, ``FR, FL, RR, RL`` x ``(hip, thigh, calf)``; joint ``i``
is ``qpos[7 + i]``/``qvel[6 + i]`` and actuator ``i``.

Joint dynamics: the original's URDF joint limits (``JOINT_RANGES``) replace Menagerie's wider ones; its joints have
no damping or friction (the PD's ``KD`` is the only damping), so Menagerie's joint damping (1-2 N m s/rad) and
friction loss (0.2 N m) are removed. Menagerie's rotor armature (0.01 kg m^2, the Go1's reflected rotor inertia) is
kept: with the explicit ``-KD * qdot`` term at 5 ms, a swinging calf (about 0.006 kg m^2 about the knee) alone would
be past the explicit damping limit ``KD * dt / I < 2``. The joint limits are stiff (``JOINT_LIMIT_SOLREF``,
``JOINT_LIMIT_SOLIMP``): IsaacGym enforces them as hard constraints, and with MuJoCo's default soft limits (time
constant 0.02 s, impedance 0.9-0.95) the saturated PD torques pushed trained policies' hips 0.2-0.5 rad past the URDF
range in 17-33% of the steps (legs splayed sideways; up to 2.3 rad in a fall) and the calves past the knee stop in
18-90%; with the stiff limits, 0-3% (tests/test_parkour_physics.py, docs/parkour.md).

Collision geometry (``terrain_collision`` below): Menagerie's 42 collision primitives (several overlapping capsules
and cylinders per link, trunk box + 2 cylinders + 6 head capsules) are replaced by a URDF-like set, the shapes of
the original's ``go1_with_camera.urdf`` after IsaacGym's ``replace_cylinder_with_capsule``: one trunk box, one hip
capsule, one thigh capsule and one calf capsule per leg (capsules instead of the URDF's thin link boxes: one
smooth support function, the cheapest convex shape after the sphere for the terrain's per-prism GJK) and one foot
sphere per leg (URDF radius 2 cm) in its own ``*_foot`` body, so that foot forces (contact state) and thigh/calf
forces (collision penalty) are separate per-body contact forces, as in IsaacGym. The robot does not collide with
itself (the original disables self-collisions). Robot geoms have priority over the terrain, so a contact uses the
robot geom's per-world friction (see ``scene.py``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ...assets import menagerie_dir

LEGS = ("FR", "FL", "RR", "RL")
JOINT_NAMES = tuple(f"{leg}_{part}_joint" for leg in LEGS for part in ("hip", "thigh", "calf"))
NUM_JOINTS = 12
# hip +0.1 on the left legs, -0.1 on the right; thigh 0.8 front / 1.0 rear; calf -1.5 (FR, FL, RR, RL x hip/thigh/calf)
DEFAULT_JOINT_POS = np.array([-0.1, 0.8, -1.5, 0.1, 0.8, -1.5, -0.1, 1.0, -1.5, 0.1, 1.0, -1.5])
KP = 50.0  # N m / rad
KD = 3.0  # N m s / rad
TORQUE_LIMIT = 33.5  # N m (URDF effort limit)
ACTION_SCALE = 1.0
ACTION_CLIP = 5.0  # |action| <= ACTION_CLIP / ACTION_SCALE
SIM_DT = 0.005  # s
DECIMATION = 4  # physics steps per policy step (policy at 50 Hz)
BASE_INIT_HEIGHT = 0.42  # m above the spawn origin
JOINT_ARMATURE = 0.01  # kg m^2, Menagerie's value
# joint limit constraints: the stiffest stable time constant at SIM_DT (2 dt) and near-hard impedance
JOINT_LIMIT_SOLREF = (0.01, 1.0)
JOINT_LIMIT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
MODEL_VERSION = "go1-2026-11-24-stiff-limits"
"""Changes whenever the robot's physics changes, so that flat pre-training checkpoints of an older model are not
reused (it is part of the pre-training stage key)."""
# joint position limits of the original's URDF (go1_with_camera.urdf; IsaacGym enforces them), rad: Menagerie's are
# wider (hip +-0.863, thigh -0.686..4.501, calf -2.818..-0.888)
JOINT_RANGES = {"hip": (-0.802851455917, 0.802851455917), "thigh": (-1.0471975512, 4.18879020479),
                "calf": (-2.69653369433, -0.916297857297)}

BASE_BODY = "trunk"
FOOT_BODIES = tuple(f"{leg}_foot" for leg in LEGS)
THIGH_BODIES = tuple(f"{leg}_thigh" for leg in LEGS)
CALF_BODIES = tuple(f"{leg}_calf" for leg in LEGS)

# Collision filtering: robot geoms (contype ROBOT_BIT, conaffinity 0) touch the terrain (contype 0, conaffinity
# ROBOT_BIT) and never each other.
ROBOT_BIT = 2
# Which robot geoms collide with the terrain: "feet" (4 spheres), "legs" (+ calf and thigh capsules), "all"
# (+ hip capsules and the trunk box). The collision penalty needs thigh/calf contacts ("legs" or "all").
TERRAIN_COLLISIONS = ("feet", "legs", "all")
# the default of the env, the scene and the benchmarks: the original's set (without the trunk, policies learn to
# crawl with the trunk inside the ground)
DEFAULT_TERRAIN_COLLISION = "all"

# URDF-like collision shapes (link frames of the Menagerie model, which has the URDF's kinematics)
TRUNK_HALF_SIZE = (0.1881, 0.04675, 0.057)  # URDF trunk box 0.3762 x 0.0935 x 0.114
HIP_RADIUS, HIP_HALF_LENGTH, HIP_OFFSET = 0.046, 0.02, 0.045  # URDF hip cylinder r 0.046, length 0.04, y +-0.045
THIGH_RADIUS, THIGH_FROMTO = 0.015, (0.0, 0.0, -0.015, 0.0, 0.0, -0.198)  # URDF box 0.213 x 0.0245 x 0.034
CALF_RADIUS, CALF_FROMTO = 0.008, (0.0, 0.0, -0.008, 0.0, 0.0, -0.19)  # URDF box 0.213 x 0.016 x 0.016
FOOT_RADIUS, FOOT_POS = 0.02, (0.0, 0.0, -0.213)


def _collision_class(body_name: str) -> str:
    if body_name in FOOT_BODIES:
        return "feet"
    if body_name in THIGH_BODIES or body_name in CALF_BODIES:
        return "legs"
    return "all"


def go1_spec(terrain_collision: str = DEFAULT_TERRAIN_COLLISION) -> mujoco.MjSpec:
    """Menagerie Go1 with PD actuators, URDF-like collision shapes, foot bodies and the original's joint dynamics.

    Args:
        terrain_collision: which robot geoms can touch the terrain, one of ``TERRAIN_COLLISIONS``; the others keep
            their shape (and the robot its mass) but never make contacts.
    """
    if terrain_collision not in TERRAIN_COLLISIONS:
        raise ValueError(f"unknown terrain_collision {terrain_collision!r}; valid choices: "
                         f"{', '.join(TERRAIN_COLLISIONS)}")
    enabled = TERRAIN_COLLISIONS[: TERRAIN_COLLISIONS.index(terrain_collision) + 1]
    spec = mujoco.MjSpec.from_file(str(menagerie_dir("unitree_go1") / "go1.xml"))
    spec.option.timestep = SIM_DT
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    for item in list(spec.actuators) + list(spec.keys) + list(spec.lights):
        spec.delete(item)
    for geom in list(spec.geoms):
        if geom.contype or geom.conaffinity:
            spec.delete(geom)
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            joint.damping = [0.0, 0.0, 0.0]
            joint.frictionloss = 0.0
            joint.armature = JOINT_ARMATURE
            joint.range = JOINT_RANGES[joint.name.split("_")[1]]
            joint.solref_limit = list(JOINT_LIMIT_SOLREF)
            joint.solimp_limit = list(JOINT_LIMIT_SOLIMP)

    def add_collision(body: mujoco.MjsBody, name: str, **kwargs) -> None:
        on = _collision_class(body.name) in enabled
        body.add_geom(name=name, group=3, rgba=[0.8, 0.3, 0.3, 0.4], contype=ROBOT_BIT if on else 0, conaffinity=0,
                      condim=3, priority=1, friction=[1.0, 0.005, 0.0001], margin=0.0, mass=0.0, **kwargs)

    add_collision(spec.body(BASE_BODY), "trunk_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(TRUNK_HALF_SIZE))
    for leg in LEGS:
        side = 1.0 if leg[1] == "L" else -1.0
        add_collision(spec.body(f"{leg}_hip"), f"{leg}_hip_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                      size=[HIP_RADIUS, HIP_HALF_LENGTH, 0.0], pos=[0.0, side * HIP_OFFSET, 0.0],
                      quat=[np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0])
        add_collision(spec.body(f"{leg}_thigh"), f"{leg}_thigh_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                      size=[THIGH_RADIUS, 0.0, 0.0], fromto=list(THIGH_FROMTO))
        calf = spec.body(f"{leg}_calf")
        add_collision(calf, f"{leg}_calf_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                      size=[CALF_RADIUS, 0.0, 0.0], fromto=list(CALF_FROMTO))
        # a massless body welded to the calf: its contact force is the foot's alone
        foot = calf.add_body(name=f"{leg}_foot", pos=list(FOOT_POS))
        add_collision(foot, f"{leg}_foot_sphere", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[FOOT_RADIUS, 0.0, 0.0])
    for i, name in enumerate(JOINT_NAMES):
        spec.add_actuator(
            name=name.replace("_joint", ""),
            target=name,
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            gainprm=[KP] + [0.0] * 9,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            biasprm=[0.0, -KP, -KD] + [0.0] * 7,
            forcelimited=True,
            forcerange=[-TORQUE_LIMIT, TORQUE_LIMIT],
            ctrllimited=False,
        )
    return spec


def standing_qpos(base_pos: tuple[float, float, float] = (0.0, 0.0, BASE_INIT_HEIGHT)) -> np.ndarray:
    """``qpos`` (19) of the Go1 upright at ``base_pos`` with the default joint angles."""
    return np.concatenate([np.asarray(base_pos, dtype=float), [1.0, 0.0, 0.0, 0.0], DEFAULT_JOINT_POS])

