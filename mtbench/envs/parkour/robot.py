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
the original's ``go1_with_camera.urdf`` after IsaacGym's ``replace_cylinder_with_capsule``: one trunk box, the
camera-module box in front of it (the URDF's ``imu_link`` collision box, which ``collapse_fixed_joints`` merges into
the trunk: 5 x 11 x 17 cm, reaching 10 cm ahead of the trunk box and 5 cm above it), one hip capsule, one thigh capsule and one calf capsule per leg (capsules instead of the URDF's thin link boxes: one
smooth support function, the cheapest convex shape after the sphere for the terrain's per-prism GJK) and one foot
sphere per leg (URDF radius 2 cm) in its own ``*_foot`` body, so that foot forces (contact state) and thigh/calf
forces (collision penalty) are separate per-body contact forces, as in IsaacGym. The robot does not collide with
itself (the original disables self-collisions). Robot geoms have priority over the terrain, so a contact uses the
robot geom's per-world friction (see ``scene.py``).

Inertial model (``inertia`` below, the env's ``robot_inertia``): ``"menagerie"`` (default) keeps Menagerie's masses,
centres of mass and inertias (12.74 kg: trunk 5.204, hip 0.68, thigh 1.009, calf 0.196 kg, massless feet) and its
rotor armature. ``"urdf"`` uses the original's ``go1_with_camera.urdf`` (MTBench commit ed2e2b5; ``URDF_INERTIALS``)
for every link: mass, centre of mass and the full inertia tensor (the URDF gives off-diagonal terms; MuJoCo
diagonalises it into ``body_inertia``/``body_iquat``), 11.31 kg: trunk 4.8 kg + the 1 g ``imu_link`` (a fixed child
of the trunk, merged into it as IsaacGym's ``collapse_fixed_joints`` does), hip 0.510, thigh 0.899, calf 0.158 and
a 60 g foot at the foot sphere's centre (the ``*_foot`` bodies, the URDF's ``*_foot`` links, kept apart by IsaacGym
through ``dont_collapse``). The two models' kinematic frames are the same (URDF joint origins = Menagerie body
positions, no rotated frames, same joint axes; checked by ``tests/test_go1_inertia.py``), so the URDF's inertial
blocks go into Menagerie's bodies unchanged. Armature: the original has none (``asset.armature: 0``), but the
explicit PD is unstable without it (the stability argument above; the URDF's calf is 0.0087 kg m^2 about the knee
with its foot, yet a swinging leg's joints see much less); ``URDF_JOINT_ARMATURE`` (0.007 kg m^2) is the smallest
value measured to keep it stable (docs/parkour.md, "Inertial model"). ``model_version(inertia, armature,
integrator)`` keys the flat pre-training stage per model.

Integrator (the env's ``robot_integrator``): ``"euler"`` (default) integrates the PD's ``-ms1 * KD * qdot`` term
explicitly, which needs the armature above to be stable. ``"implicitfast"`` (MuJoCo's implicit-in-velocity
integrator) takes the derivative of every unclamped actuator force with respect to the joint velocities into the
step, so the damping term is integrated implicitly and the joints are stable without armature: with the env's
``robot_armature=0`` and ``robot_inertia="urdf"`` this is the original's armature-free URDF Go1 (a clamped torque
contributes no derivative, as the original's clipped torque has none).
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
# the robot's contacts with the terrain (its geoms have priority, so their solref is the contact's): time constant
# 0.01 s by default (a standing Go1's feet sink 1.2 mm), the stiffest MuJoCo allows at SIM_DT; PhysX's contacts (the
# original) are rigid. ``None`` keeps MuJoCo's own 0.02 s (soft: 5 mm standing, 1-2 cm at impacts; the default before
# 2026-11-29: on the jump terrains the policies stopped at the first gap, docs/parkour.md). Bounds: MuJoCo needs at
# least 2 timesteps; at 0.05 s a standing Go1 already sinks 28 mm.
DEFAULT_CONTACT_TIMECONST = 0.01
MUJOCO_CONTACT_TIMECONST = 0.02
CONTACT_TIMECONST_RANGE = (2 * SIM_DT, 0.05)
JOINT_LIMIT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
# integrators of the robot's physics: explicit Euler (default) or MuJoCo's implicitfast (implicit actuator damping)
INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}
DEFAULT_INTEGRATOR = "euler"
MODEL_VERSION = "go1-2026-11-28-camera-box-com-velocity"
"""Changes whenever the robot's physics, or what the env measures of it, changes, so that flat pre-training
checkpoints of an older model are not reused (it is part of the pre-training stage key, through
:func:`model_version`). 2026-11-28: the URDF's camera-module box; the base velocity is the trunk's centre of mass's;
the scan points turn by the original's ``quat_apply_yaw`` heading."""
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
# URDF imu_link collision box ("front face camera module", 0.05 x 0.11 x 0.17) at imu_link + (0.28, 0.06659, 0.0325),
# imu_link at trunk + URDF_IMU_POS: in the trunk frame centred at (0.26408, 0, 0.02633)
CAMERA_BOX_HALF_SIZE = (0.025, 0.055, 0.085)
CAMERA_BOX_POS = (0.26408, 0.0, 0.02633)
HIP_RADIUS, HIP_HALF_LENGTH, HIP_OFFSET = 0.046, 0.02, 0.045  # URDF hip cylinder r 0.046, length 0.04, y +-0.045
THIGH_RADIUS, THIGH_FROMTO = 0.015, (0.0, 0.0, -0.015, 0.0, 0.0, -0.198)  # URDF box 0.213 x 0.0245 x 0.034
CALF_RADIUS, CALF_FROMTO = 0.008, (0.0, 0.0, -0.008, 0.0, 0.0, -0.19)  # URDF box 0.213 x 0.016 x 0.016
FOOT_RADIUS, FOOT_POS = 0.02, (0.0, 0.0, -0.213)
# Collision pieces: MuJoCo Warp's heightfield collision runs one thread per robot-geom/heightfield pair, and that
# thread runs GJK/EPA on every prism under the geom's bounding box that reaches its lowest point (the trunk box:
# ~60-100 prisms in a step of a trained policy's worlds; docs/benchmarks.md section 7). Cutting each box along its
# longest side, and each capsule whose segment is longer than its radius along that segment, into N equal pieces keeps
# the same solid in N pairs of ~1/N the prisms each. Measured on an H200 it does not pay (at N = 4 the heightfield
# kernels -11%, the rollout's frames/s -10%: the per-pair stages grow), so the default is whole shapes.
COLLISION_PIECES_RANGE = (1, 8)
DEFAULT_COLLISION_PIECES = 1


# Inertial models: Menagerie's (default) or the original URDF's (module docstring).
INERTIAL_MODELS = ("menagerie", "urdf")
DEFAULT_INERTIAL_MODEL = "menagerie"
# kg m^2 with inertia="urdf". The original has none (asset.armature 0), but with the explicit -KD qdot at 5 ms the
# URDF's legs need some: the smallest value (0.5 g m^2 steps) that keeps the explicit damping stable in the worst case
# (largest eigenvalue of dt * 1.2 KD * (M^-1)_joints below 2 over 300 random free-floating poses: 1.87; armature 0:
# 6.8, and a standing Go1 chatters and sags to 0.19 m). Measurements: docs/parkour.md, "Inertial model".
URDF_JOINT_ARMATURE = 0.007
# go1_with_camera.urdf's inertial blocks (MTBench commit ed2e2b5), link -> (mass kg, centre of mass xyz m in the link
# frame, inertia about the centre of mass (ixx, iyy, izz, ixy, ixz, iyz) kg m^2); every origin rpy is 0. Copied
# verbatim, asymmetries included (the calf's is the same on both sides; the hip's x and y signs follow the leg).
_HIP_I, _THIGH_I = (0.00030528937, 0.000590894859, 0.000396594572), (0.005395867678, 0.005142451046, 0.00102478732)
_CALF = (0.158015, (0.006286, 0.001307, -0.122269),
         (0.003607648222, 0.003626771492, 3.5148003e-05, 1.494971e-06, -0.000132778525, -2.8638535e-05))
_FOOT = (0.06, (0.0, 0.0, 0.0), (9.6e-06, 9.6e-06, 9.6e-06, 0.0, 0.0, 0.0))
URDF_INERTIALS = {
    "trunk": (4.8, (0.011611, 0.004437, 0.000108),
              (0.016130741919, 0.036507810812, 0.044693872053, 0.000593180607, 7.324662e-06, 2.0969537e-05)),
    "imu_link": (0.001, (0.0, 0.0, 0.0), (0.0001, 0.0001, 0.0001, 0.0, 0.0, 0.0)),
    "FR_hip": (0.510299, (-0.00541, 0.00074, 6e-06), _HIP_I + (7.788013e-06, 2.2016e-07, 1.7175e-08)),
    "FL_hip": (0.510299, (-0.00541, -0.00074, 6e-06), _HIP_I + (-7.788013e-06, 2.2016e-07, -1.7175e-08)),
    "RR_hip": (0.510299, (0.00541, 0.00074, 6e-06), _HIP_I + (-7.788013e-06, -2.2016e-07, 1.7175e-08)),
    "RL_hip": (0.510299, (0.00541, -0.00074, 6e-06), _HIP_I + (7.788013e-06, -2.2016e-07, -1.7175e-08)),
    "FR_thigh": (0.898919, (-0.003468, 0.018947, -0.032736), _THIGH_I + (-1.02809e-07, 0.000337529085, 5.816563e-06)),
    "FL_thigh": (0.898919, (-0.003468, -0.018947, -0.032736), _THIGH_I + (1.02809e-07, 0.000337529085, -5.816563e-06)),
    "RR_thigh": (0.898919, (-0.003468, 0.018947, -0.032736), _THIGH_I + (-1.02809e-07, 0.000337529085, 5.816563e-06)),
    "RL_thigh": (0.898919, (-0.003468, -0.018947, -0.032736), _THIGH_I + (1.02809e-07, 0.000337529085, -5.816563e-06)),
    **{f"{leg}_calf": _CALF for leg in LEGS},
    **{f"{leg}_foot": _FOOT for leg in LEGS},
}
URDF_IMU_POS = (-0.01592, -0.06659, -0.00617)  # imu_joint origin in the trunk frame


def _inertia_matrix(full: tuple[float, ...]) -> np.ndarray:
    ixx, iyy, izz, ixy, ixz, iyz = full
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def merge_inertials(parts: list[tuple[float, np.ndarray, np.ndarray]]) -> tuple[float, np.ndarray, np.ndarray]:
    """Rigidly joined bodies ``(mass, centre of mass [3], inertia about it [3, 3])`` in one frame as one body (the
    parallel-axis theorem): its ``(mass, centre of mass, inertia about it)``."""
    mass = sum(m for m, _, _ in parts)
    com = sum(m * np.asarray(c, dtype=float) for m, c, _ in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, i in parts:
        d = np.asarray(c, dtype=float) - com
        inertia += np.asarray(i, dtype=float) + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, com, inertia


def urdf_body_inertials() -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """The ``"urdf"`` model's ``body -> (mass, centre of mass, inertia matrix about it)`` in Menagerie's body frames
    (the trunk with the URDF's ``imu_link`` merged in)."""
    bodies = {name: (mass, np.asarray(com, dtype=float), _inertia_matrix(full))
              for name, (mass, com, full) in URDF_INERTIALS.items() if name not in ("trunk", "imu_link")}
    trunk, imu = URDF_INERTIALS["trunk"], URDF_INERTIALS["imu_link"]
    bodies[BASE_BODY] = merge_inertials([
        (trunk[0], np.asarray(trunk[1]), _inertia_matrix(trunk[2])),
        (imu[0], np.asarray(URDF_IMU_POS) + np.asarray(imu[1]), _inertia_matrix(imu[2])),
    ])
    return bodies


def joint_armature(inertia: str = DEFAULT_INERTIAL_MODEL, armature: float | None = None) -> float:
    """The joints' rotor armature (kg m^2): ``armature`` if given, else the inertial model's (``JOINT_ARMATURE`` for
    ``"menagerie"``, ``URDF_JOINT_ARMATURE`` for ``"urdf"``)."""
    _check_inertia(inertia)
    if armature is None:
        return JOINT_ARMATURE if inertia == "menagerie" else URDF_JOINT_ARMATURE
    if isinstance(armature, bool) or not isinstance(armature, (int, float)) or not 0.0 <= float(armature) <= 1.0:
        raise ValueError(f"robot_armature must be a number in [0, 1] kg m^2 (or None: the inertial model's); "
                         f"got {armature!r}")
    return float(armature)


def model_version(inertia: str = DEFAULT_INERTIAL_MODEL, armature: float | None = None,
                  integrator: str = DEFAULT_INTEGRATOR,
                  contact_timeconst: float | None = DEFAULT_CONTACT_TIMECONST,
                  collision_pieces: int = DEFAULT_COLLISION_PIECES) -> str:
    """The robot model's version for the flat pre-training key: ``MODEL_VERSION`` for Menagerie's inertials and
    armature, Euler and MuJoCo's own contact time constant (``contact_timeconst=None``; the key of every stage before
    the stiffer default), ``MODEL_VERSION`` plus the inertial model, the armature, a non-default integrator and the
    contact time constant otherwise (the default model: ``MODEL_VERSION + "+contact-0.01"``), and the collision
    pieces when more than one (``+pieces-N``)."""
    value = joint_armature(inertia, armature)
    pieces = check_collision_pieces(collision_pieces)
    _check_integrator(integrator)
    contact = check_contact_timeconst(contact_timeconst)
    parts = [MODEL_VERSION]
    if not (inertia == DEFAULT_INERTIAL_MODEL and value == JOINT_ARMATURE and integrator == DEFAULT_INTEGRATOR):
        joints = f"{inertia}-inertia-armature-{value:g}"
        parts.append(joints if integrator == DEFAULT_INTEGRATOR else f"{joints}-{integrator}")
    if contact is not None:
        parts.append(f"contact-{contact:g}")
    if pieces != 1:
        parts.append(f"pieces-{pieces}")
    return "+".join(parts)


def check_contact_timeconst(value: float | None) -> float | None:
    """``value`` as a float (None: MuJoCo's own 0.02 s), or a ValueError naming ``robot_contact_timeconst`` and its
    range (``CONTACT_TIMECONST_RANGE``)."""
    if value is None:
        return None
    low, high = CONTACT_TIMECONST_RANGE
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= float(value) <= high:
        raise ValueError(f"robot_contact_timeconst must be a number of seconds in [{low:g}, {high:g}] (or null: "
                         f"MuJoCo's {MUJOCO_CONTACT_TIMECONST:g}); got {value!r}")
    return float(value)


def check_collision_pieces(value: int) -> int:
    """``value`` as an int, or a ValueError naming ``robot_collision_pieces`` and its range
    (``COLLISION_PIECES_RANGE``)."""
    low, high = COLLISION_PIECES_RANGE
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= int(value) <= high:
        raise ValueError(f"robot_collision_pieces must be an integer in [{low}, {high}] (1: each collision shape "
                         f"whole); got {value!r}")
    return int(value)


def is_split(geom_type: int, size: "np.ndarray | list[float]") -> bool:
    """Whether ``robot_collision_pieces`` cuts a collision geom of this MuJoCo type and ``size``: every box (along
    its longest side) and every capsule whose half-segment is longer than its radius (the thighs and calves; not the
    short, thick hip capsules, whose bounding box a cut hardly shrinks); never a sphere."""
    if geom_type == mujoco.mjtGeom.mjGEOM_BOX:
        return True
    return geom_type == mujoco.mjtGeom.mjGEOM_CAPSULE and float(size[1]) > float(size[0])


def box_pieces(pos: "list[float] | tuple[float, ...]", half_size: "list[float] | tuple[float, ...]",
               pieces: int) -> list[tuple[list[float], list[float]]]:
    """A box (centre ``pos``, ``half_size`` in its body frame, axis-aligned there) as ``pieces`` equal boxes along its
    longest side: ``[(centre, half_size), ...]``, which tile the box exactly."""
    axis = int(np.argmax(half_size))
    out = []
    for k in range(pieces):
        centre, size = list(map(float, pos)), list(map(float, half_size))
        size[axis] = half_size[axis] / pieces
        centre[axis] = pos[axis] - half_size[axis] + (2 * k + 1) * size[axis]
        out.append((centre, size))
    return out


def segment_pieces(fromto: "list[float] | tuple[float, ...]", pieces: int) -> list[list[float]]:
    """A capsule's segment ``fromto`` (6 numbers) as ``pieces`` consecutive equal segments: capsules of the same
    radius on them make exactly the same solid."""
    a, b = np.asarray(fromto[:3], dtype=float), np.asarray(fromto[3:], dtype=float)
    return [list(a + (b - a) * k / pieces) + list(a + (b - a) * (k + 1) / pieces) for k in range(pieces)]


def _check_inertia(inertia: str) -> None:
    if inertia not in INERTIAL_MODELS:
        raise ValueError(f"unknown robot inertia {inertia!r}; valid choices: {', '.join(INERTIAL_MODELS)}")


def _check_integrator(integrator: str) -> None:
    if integrator not in INTEGRATORS:
        raise ValueError(f"unknown robot_integrator {integrator!r}; valid choices: {', '.join(INTEGRATORS)}")


def _collision_class(body_name: str) -> str:
    if body_name in FOOT_BODIES:
        return "feet"
    if body_name in THIGH_BODIES or body_name in CALF_BODIES:
        return "legs"
    return "all"


def go1_spec(terrain_collision: str = DEFAULT_TERRAIN_COLLISION, inertia: str = DEFAULT_INERTIAL_MODEL,
             armature: float | None = None, integrator: str = DEFAULT_INTEGRATOR,
             contact_timeconst: float | None = DEFAULT_CONTACT_TIMECONST,
             collision_pieces: int = DEFAULT_COLLISION_PIECES) -> mujoco.MjSpec:
    """Menagerie Go1 with PD actuators, URDF-like collision shapes, foot bodies and the original's joint dynamics.

    Args:
        terrain_collision: which robot geoms can touch the terrain, one of ``TERRAIN_COLLISIONS``; the others keep
            their shape (and the robot its mass) but never make contacts.
        inertia: the links' masses, centres of mass and inertias (and the joints' armature), one of
            ``INERTIAL_MODELS``: ``"menagerie"`` (default) or ``"urdf"`` (the original's; module docstring).
        armature: joint rotor armature (kg m^2, in [0, 1]) instead of the model's (``JOINT_ARMATURE`` /
            ``URDF_JOINT_ARMATURE``); below ~0.007 the explicit PD needs ``integrator="implicitfast"``.
        integrator: ``"euler"`` (default) or ``"implicitfast"`` (``INTEGRATORS``; module docstring).
        contact_timeconst: the time constant (s) of the robot's terrain contacts (its collision geoms' solref,
            damping ratio 1; ``DEFAULT_CONTACT_TIMECONST`` by default, ``None``: MuJoCo's own 0.02); smaller is stiffer
            (``CONTACT_TIMECONST_RANGE``).
        collision_pieces: each box and long capsule of the collision set as this many equal pieces along its
            longest axis (``is_split``; named ``<name>_<k>``): the same solids, in more and shorter heightfield
            collision threads on the GPU (``COLLISION_PIECES_RANGE``; 1: each shape whole, named ``<name>``).
    """
    if terrain_collision not in TERRAIN_COLLISIONS:
        raise ValueError(f"unknown terrain_collision {terrain_collision!r}; valid choices: "
                         f"{', '.join(TERRAIN_COLLISIONS)}")
    armature = joint_armature(inertia, armature)
    _check_integrator(integrator)
    contact = check_contact_timeconst(contact_timeconst)
    pieces = check_collision_pieces(collision_pieces)
    solref = {} if contact is None else {"solref": [contact, 1.0]}
    enabled = TERRAIN_COLLISIONS[: TERRAIN_COLLISIONS.index(terrain_collision) + 1]
    spec = mujoco.MjSpec.from_file(str(menagerie_dir("unitree_go1") / "go1.xml"))
    spec.option.timestep = SIM_DT
    spec.option.integrator = INTEGRATORS[integrator]
    for item in list(spec.actuators) + list(spec.keys) + list(spec.lights):
        spec.delete(item)
    for geom in list(spec.geoms):
        if geom.contype or geom.conaffinity:
            spec.delete(geom)
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            joint.damping = [0.0, 0.0, 0.0]
            joint.frictionloss = 0.0
            joint.armature = armature
            joint.range = JOINT_RANGES[joint.name.split("_")[1]]
            joint.solref_limit = list(JOINT_LIMIT_SOLREF)
            joint.solimp_limit = list(JOINT_LIMIT_SOLIMP)

    def add_geom(body: mujoco.MjsBody, name: str, **kwargs) -> None:
        on = _collision_class(body.name) in enabled
        body.add_geom(name=name, group=3, rgba=[0.8, 0.3, 0.3, 0.4], contype=ROBOT_BIT if on else 0, conaffinity=0,
                      condim=3, priority=1, friction=[1.0, 0.005, 0.0001], margin=0.0, mass=0.0, **solref, **kwargs)

    def add_collision(body: mujoco.MjsBody, name: str, **kwargs) -> None:
        kind, size = kwargs["type"], kwargs["size"]
        if kind == mujoco.mjtGeom.mjGEOM_CAPSULE and "fromto" in kwargs:
            a, b = np.asarray(kwargs["fromto"][:3]), np.asarray(kwargs["fromto"][3:])
            size = [size[0], 0.5 * float(np.linalg.norm(b - a))]
        if pieces == 1 or not is_split(kind, size):
            add_geom(body, name, **kwargs)
        elif kind == mujoco.mjtGeom.mjGEOM_BOX:
            for k, (pos, half) in enumerate(box_pieces(kwargs.get("pos", [0.0, 0.0, 0.0]), size, pieces)):
                add_geom(body, f"{name}_{k}", **{**kwargs, "pos": pos, "size": half})
        else:  # a capsule given by its segment (the thighs and calves)
            for k, fromto in enumerate(segment_pieces(kwargs["fromto"], pieces)):
                add_geom(body, f"{name}_{k}", **{**kwargs, "fromto": fromto})

    add_collision(spec.body(BASE_BODY), "trunk_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(TRUNK_HALF_SIZE))
    add_collision(spec.body(BASE_BODY), "camera_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(CAMERA_BOX_HALF_SIZE),
                  pos=list(CAMERA_BOX_POS))
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
    if inertia == "urdf":
        for name, (mass, com, matrix) in urdf_body_inertials().items():
            body = spec.body(name)
            body.explicitinertial = True
            body.mass, body.ipos, body.iquat, body.inertia = mass, list(com), [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
            body.fullinertia = [matrix[0, 0], matrix[1, 1], matrix[2, 2], matrix[0, 1], matrix[0, 2], matrix[1, 2]]
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

