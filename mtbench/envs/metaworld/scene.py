"""Build one Meta-World task scene: the task's own MJCF (table, objects, fixtures) with the Sawyer removed and
the Menagerie Panda attached, driven through a mocap weld. Pure MuJoCo (``MjSpec``), compiled once per task."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import mujoco
import numpy as np

from ...assets import metaworld_assets_dir
from . import robot

# Panda base on the table, facing +y (Meta-World's forward axis). Chosen so that the hand workspace of every task
# (y in [0.4, 0.95], z in [0.0, 0.3] above the table) is reachable with the hand pointing down.
ROBOT_BASE_POS = np.array([0.0, 0.15, 0.0])
ROBOT_BASE_QUAT = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])  # +90 deg about z
# physics options (Meta-World: dt 2.5 ms x 5 substeps = 12.5 ms control, Newton, elliptic cones; we use 4 ms x 3 =
# 12 ms control, which keeps all contact time constants >= 2 dt; MuJoCo Warp supports Euler, not implicitfast)
TIMESTEP = 0.004
SOLVER_ITERATIONS = 20
LS_ITERATIONS = 10
SOLVER_TOLERANCE = 1e-6
HOME_KEY = "home"
# joint limit of a fixture part held by its joint alone (see ``guide_by_joint``): time constant 2 x timestep (the
# smallest that stays stable), hard impedance
STIFF_LIMIT_SOLREF = (0.008, 1.0)
STIFF_LIMIT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)


@dataclass(frozen=True)
class SceneSpec:
    """What a task needs from its scene: the Meta-World XML and the initial hand position."""

    xml: str
    hand_init_pos: tuple[float, float, float] = (0.0, 0.6, 0.2)


def _strip_sawyer(spec: mujoco.MjSpec) -> None:
    spec.delete(spec.body("base"))
    spec.delete(spec.body("mocap"))
    for act in list(spec.actuators):
        spec.delete(act)
    for eq in list(spec.equalities):
        spec.delete(eq)
    # Sawyer meshes are now unreferenced; drop them so they are neither compiled nor uploaded
    used = {g.meshname for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_MESH}
    for mesh in list(spec.meshes):
        if mesh.name not in used:
            spec.delete(mesh)
    # the near retaining wall would sit inside the robot base (some scenes have no retaining wall)
    wall = spec.body("RetainingWall")
    for geom in (list(wall.geoms) if wall is not None else []):
        if geom.pos[1] < -0.3:
            spec.delete(geom)


def _table_top_as_plane(spec: mujoco.MjSpec) -> None:
    """Replace the table's collision box by a collision plane at its top surface (same contact parameters).

    Box-versus-mesh and box-versus-cylinder pairs (fingers, hand and pucks on the table) go through MuJoCo Warp's
    general convex collision (GJK/EPA), which was about 70% of the GPU time of a contact-rich MT10 step; plane
    pairs use closed-form primitive routines. The surface height is unchanged; the plane is unbounded, so an object
    pushed over the table's side edge rests at table height instead of falling (the back edge has its wall).
    """
    table = spec.body("tablelink")
    boxes = [g for g in table.geoms if g.type == mujoco.mjtGeom.mjGEOM_BOX and g.conaffinity]
    if len(boxes) > 1:  # a table top with a hole is made of several boxes (hand_insert, sweep_into_goal): keep them
        return
    if len(boxes) != 1:
        raise RuntimeError(f"expected one colliding box on 'tablelink', found {len(boxes)}")
    box = boxes[0]
    if not np.allclose(box.quat, [1.0, 0.0, 0.0, 0.0]) or not np.allclose(table.quat, [1.0, 0.0, 0.0, 0.0]):
        raise RuntimeError("the table's collision box is rotated; cannot replace its top by a plane")
    table.add_geom(
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        pos=[box.pos[0], box.pos[1], box.pos[2] + box.size[2]],
        size=[box.size[0], box.size[1], 0.01],
        contype=box.contype,
        conaffinity=box.conaffinity,
        condim=box.condim,
        friction=box.friction,
        solref=box.solref,
        solimp=box.solimp,
        group=box.group,
    )
    box.contype, box.conaffinity = 0, 0


def guide_by_joint(spec: mujoco.MjSpec, part: str, joint: str, frame: Sequence[str]) -> None:
    """Let a jointed fixture part (drawer, window sash, door, button) be guided by its joint alone: exclude its
    contacts with the static ``frame`` bodies it slides or turns in, and make the joint limit stiff.

    The joint already confines the part to its path; the frame contacts only matter when the arm shoves the part
    past its soft joint limit, where box-box pairs against the frame add up to 8 contacts each and a stiff
    weld-versus-frame conflict (the drawer scene reached 35 contacts per world and the Newton iteration cap, the
    slowest MT10 block on the GPU). A stiff limit ends the travel within millimetres of its range instead.
    """
    for body in (part, *frame):
        if spec.body(body) is None:
            raise ValueError(f"guide_by_joint: no body {body!r} in the scene")
    jnt = spec.joint(joint)
    if jnt is None:
        raise ValueError(f"guide_by_joint: no joint {joint!r} in the scene")
    for body in frame:
        spec.add_exclude(bodyname1=part, bodyname2=body)
    jnt.solref_limit = list(STIFF_LIMIT_SOLREF)
    jnt.solimp_limit = list(STIFF_LIMIT_SOLIMP)


def build_scene(
    scene: SceneSpec,
    edit_spec: Callable[[mujoco.MjSpec], None] | None = None,
    robot_collision: str = "primitive",
) -> mujoco.MjModel:
    """Compile the task scene with the Panda at ``ROBOT_BASE_POS`` and the arm settled so that the TCP is at
    ``scene.hand_init_pos`` (stored as the ``home`` keyframe, with the mocap body at the matching hand pose).
    ``robot_collision`` selects the hand/finger collision geometry (``robot.ROBOT_COLLISIONS``)."""
    spec = mujoco.MjSpec.from_file(str(metaworld_assets_dir() / "sawyer_xyz" / scene.xml))
    _strip_sawyer(spec)
    _table_top_as_plane(spec)
    if edit_spec is not None:  # task-specific model edits (e.g. stiffer joint limits of a fixture)
        edit_spec(spec)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    spec.option.timestep = TIMESTEP
    spec.option.iterations = SOLVER_ITERATIONS
    spec.option.ls_iterations = LS_ITERATIONS
    spec.option.tolerance = SOLVER_TOLERANCE
    frame = spec.worldbody.add_frame(pos=ROBOT_BASE_POS, quat=ROBOT_BASE_QUAT)
    frame.attach_body(robot.panda_spec(robot_collision).body("link0"), robot.PREFIX, "")
    hand_pos = np.asarray(scene.hand_init_pos) + np.array([0.0, 0.0, robot.TCP_OFFSET])
    spec.worldbody.add_body(name="mocap", mocap=True, pos=hand_pos, quat=robot.HAND_DOWN_QUAT)
    spec.add_equality(
        type=mujoco.mjtEq.mjEQ_WELD,
        name1="mocap",
        name2=robot.HAND,
        objtype=mujoco.mjtObj.mjOBJ_BODY,
        data=[0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1] + [0.0],
        solref=[0.02, 1.0],
    )
    spec.add_key(name=HOME_KEY, qpos=np.zeros(0), mpos=hand_pos, mquat=robot.HAND_DOWN_QUAT)
    model = spec.compile()
    _settle_initial_pose(model)
    return model


def _settle_initial_pose(model: mujoco.MjModel, seconds: float = 2.0) -> None:
    """Let the weld pull the arm from ``READY_QPOS`` to the mocap target; store the settled configuration in the
    ``home`` keyframe (``qpos0`` must stay the reference configuration the bodies were defined in)."""
    data = mujoco.MjData(model)
    arm = [model.joint(n).qposadr[0] for n in robot.ARM_JOINTS + robot.FINGER_JOINTS]
    data.qpos[arm] = robot.READY_QPOS
    mujoco.mj_forward(model, data)
    for _ in range(int(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    key = model.key(HOME_KEY)
    key.qpos[:] = model.qpos0
    key.qpos[arm] = data.qpos[arm]
