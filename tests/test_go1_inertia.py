"""The Go1's two inertial models (``robot_inertia``): the default ``"menagerie"`` model unchanged, the ``"urdf"`` model
equal to the original's ``go1_with_camera.urdf`` (its inertial blocks and joint frames, copied from MTBench commit
ed2e2b5 into ``tests/data/go1_with_camera_inertials.urdf``), the same kinematic frames in both, its own flat
pre-training key, and a stable explicit PD with its armature (docs/parkour.md, "Inertial model")."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest
import torch

from cpu_runs import one_torch_thread
from mtbench.envs.parkour import robot
from mtbench.envs.parkour.env import ParkourEnv
from mtbench.envs.parkour.scene import build_scene
from parkour_synthetic import SyntheticConfig, synthetic_terrain

URDF = Path(__file__).parent / "data" / "go1_with_camera_inertials.urdf"


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    with one_torch_thread():
        yield


def _floats(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()])


def _urdf():
    """``links``: name -> (mass, com [3], inertia matrix [3, 3]) of every link with an inertial block; ``joints``:
    name -> (type, parent, child, origin xyz, origin rpy, axis or None, limit element or None)."""
    root = ET.parse(URDF).getroot()
    links, joints = {}, {}
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        origin, i = inertial.find("origin"), inertial.find("inertia").attrib
        origin = {"xyz": "0 0 0", "rpy": "0 0 0"} if origin is None else origin.attrib  # the feet give none
        assert np.all(_floats(origin["rpy"]) == 0), link.get("name")  # no rotated inertia frames
        matrix = np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]],
                           [i["ixz"], i["iyz"], i["izz"]]], dtype=float)
        links[link.get("name")] = (float(inertial.find("mass").get("value")), _floats(origin["xyz"]), matrix)
    for joint in root.findall("joint"):
        origin, axis = joint.find("origin"), joint.find("axis")
        joints[joint.get("name")] = (joint.get("type"), joint.find("parent").get("link"),
                                     joint.find("child").get("link"), _floats(origin.get("xyz")),
                                     _floats(origin.get("rpy")), None if axis is None else _floats(axis.get("xyz")),
                                     joint.find("limit"))
    return links, joints


def _full_inertia(m: mujoco.MjModel, body: int) -> np.ndarray:
    """A compiled body's inertia tensor about its centre of mass in the body frame (MuJoCo stores its principal
    moments ``body_inertia`` and axes ``body_iquat``)."""
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, m.body_iquat[body])
    rot = rot.reshape(3, 3)
    return rot @ np.diag(m.body_inertia[body]) @ rot.T


def test_urdf_model_has_the_urdfs_masses_and_inertias() -> None:
    links, joints = _urdf()
    m = robot.go1_spec(inertia="urdf").compile()
    # robot.py's table is the file's, link by link
    assert set(robot.URDF_INERTIALS) == set(links)
    for name, (mass, com, full) in robot.URDF_INERTIALS.items():
        assert mass == links[name][0], name
        np.testing.assert_array_equal(com, links[name][1], err_msg=name)
        np.testing.assert_array_equal(robot._inertia_matrix(full), links[name][2], err_msg=name)
    # every leg link in the Menagerie body of its name (the foot links in the *_foot bodies)
    for name, (mass, com, matrix) in links.items():
        if name in ("trunk", "imu_link"):
            continue
        body = m.body(name).id
        assert m.body_mass[body] == pytest.approx(mass, rel=1e-12), name
        np.testing.assert_allclose(m.body_ipos[body], com, rtol=0, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(_full_inertia(m, body), matrix, rtol=1e-9, atol=1e-13, err_msg=name)
    # the trunk with the imu_link (a fixed child: IsaacGym's collapse_fixed_joints merges it), parallel-axis theorem
    (m_t, c_t, i_t), (m_i, c_i, i_i) = links["trunk"], links["imu_link"]
    c_i = c_i + joints["imu_joint"][3]
    mass = m_t + m_i
    com = (m_t * c_t + m_i * c_i) / mass
    inertia = sum(i + mk * (np.dot(c - com, c - com) * np.eye(3) - np.outer(c - com, c - com))
                  for mk, c, i in ((m_t, c_t, i_t), (m_i, c_i, i_i)))
    trunk = m.body(robot.BASE_BODY).id
    assert m.body_mass[trunk] == pytest.approx(4.801, rel=1e-12)
    np.testing.assert_allclose(m.body_ipos[trunk], com, rtol=0, atol=1e-12)
    np.testing.assert_allclose(_full_inertia(m, trunk), inertia, rtol=1e-9, atol=1e-13)
    # total: 11.309932 kg (Menagerie's: 12.743448 kg), and the URDF's armature-free joints get URDF_JOINT_ARMATURE
    assert m.body_mass.sum() == pytest.approx(sum(v[0] for v in links.values()), rel=1e-12)
    assert m.body_mass.sum() == pytest.approx(11.309932, rel=1e-12)
    np.testing.assert_array_equal(m.dof_armature[6:], robot.URDF_JOINT_ARMATURE)
    # the velocity limits the notes quote (not enforced here; the PD's torque limit is)
    limits = {name: float(j[6].get("velocity")) for name, j in joints.items() if j[0] == "revolute"}
    assert {n: limits[n] for n in robot.JOINT_NAMES} == {
        n: (50.0 if "hip" in n else 28.0) for n in robot.JOINT_NAMES}


@pytest.mark.parametrize("inertia", robot.INERTIAL_MODELS)
def test_menagerie_and_urdf_kinematic_frames_agree(inertia: str) -> None:
    """Every URDF joint origin is the Menagerie body's position in its parent (no rotations anywhere), with the same
    axis and limits; so the URDF's inertial blocks need no frame change. Not in Menagerie: the URDF's ``base`` (the
    trunk's frame), ``imu_link`` (merged into the trunk) and the massless ``*_thigh_shoulder`` collision links."""
    _, joints = _urdf()
    m = robot.go1_spec(inertia=inertia).compile()
    mapped = 0
    for name, (kind, parent, child, xyz, rpy, axis, limit) in joints.items():
        if child in ("trunk", "imu_link") or child.endswith("_thigh_shoulder"):
            continue
        assert np.all(rpy == 0), name
        body = m.body(child)
        assert m.body(m.body_parentid[body.id]).name == parent, name
        np.testing.assert_allclose(m.body_pos[body.id], xyz, rtol=0, atol=1e-12, err_msg=name)
        np.testing.assert_array_equal(m.body_quat[body.id], [1.0, 0.0, 0.0, 0.0], err_msg=name)
        if kind == "revolute":
            joint = m.joint(name)
            assert joint.bodyid[0] == body.id
            np.testing.assert_array_equal(joint.axis, axis, err_msg=name)
            np.testing.assert_allclose(joint.range, [float(limit.get("lower")), float(limit.get("upper"))],
                                       rtol=0, atol=1e-12)
        else:
            assert kind == "fixed" and m.body_jntnum[body.id] == 0, name  # the feet: welded
        mapped += 1
    assert mapped == 16  # 12 revolute joints + 4 feet


def test_menagerie_model_is_unchanged() -> None:
    default = robot.go1_spec().compile()
    explicit = robot.go1_spec(inertia="menagerie").compile()
    for field in ("body_mass", "body_ipos", "body_iquat", "body_inertia", "dof_armature", "body_pos", "jnt_range"):
        np.testing.assert_array_equal(getattr(default, field), getattr(explicit, field), err_msg=field)
    # the values the default model had before robot_inertia existed (Menagerie's, massless feet, armature 0.01)
    assert default.body_mass.sum() == pytest.approx(12.743448, rel=1e-12)
    trunk = default.body(robot.BASE_BODY).id
    assert default.body_mass[trunk] == 5.204
    np.testing.assert_array_equal(default.body_inertia[trunk], [0.0716565, 0.0630105, 0.0168101])
    np.testing.assert_array_equal(default.body_ipos[trunk], [0.0223, 0.002, -0.0005])
    np.testing.assert_array_equal(default.body_inertia[default.body("FR_calf").id], [1.49767e-03, 1.48468e-03,
                                                                                     3.58427e-05])
    assert all(default.body_mass[default.body(f).id] == 0 for f in robot.FOOT_BODIES)
    np.testing.assert_array_equal(default.dof_armature[6:], 0.01)


def test_model_version_and_choice() -> None:
    assert robot.model_version() == robot.model_version("menagerie") == robot.MODEL_VERSION + "+contact-0.01"
    assert robot.model_version("urdf") != robot.model_version()
    assert robot.MODEL_VERSION in robot.model_version("urdf")  # a new MODEL_VERSION renews both keys
    for bad in (lambda: robot.go1_spec(inertia="isaac"), lambda: robot.model_version("isaac")):
        with pytest.raises(ValueError, match=r"^unknown robot inertia 'isaac'; valid choices: menagerie, urdf$"):
            bad()


def test_armature_and_integrator_choices_and_versions() -> None:
    assert robot.model_version("menagerie", 0.01, "euler") == robot.model_version()  # the default, named
    assert robot.model_version("urdf", 0.007) == robot.model_version("urdf")  # the urdf key of before
    versions = {robot.model_version(*args) for args in (
        ("menagerie",), ("urdf",), ("menagerie", 0.0), ("menagerie", None, "implicitfast"), ("urdf", 0.0, "implicitfast"))}
    assert len(versions) == 5 and all(robot.MODEL_VERSION in v for v in versions)
    assert robot.joint_armature("urdf") == robot.URDF_JOINT_ARMATURE and robot.joint_armature("urdf", 0) == 0.0
    m = robot.go1_spec(inertia="urdf", armature=0.0, integrator="implicitfast").compile()
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    np.testing.assert_array_equal(m.dof_armature[6:], 0.0)
    assert robot.go1_spec().compile().opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    with pytest.raises(ValueError, match=r"^unknown robot_integrator 'rk4'; valid choices: euler, implicitfast$"):
        robot.go1_spec(integrator="rk4")
    for bad in (-0.1, 2.0, "0.01", True):
        with pytest.raises(ValueError, match=r"^robot_armature must be a number in \[0, 1\] kg m\^2"):
            robot.model_version("urdf", bad)


def _chatter(inertia: str, armature: float | None, seconds: float, sigma: float, n: int = 8, seed: int = 0,
             integrator: str = "euler"):
    """MuJoCo C, ``n`` Go1s on a plane with the env's motor-strength randomization (ms0, ms1 ~ U(0.8, 1.2)),
    dropped from the spawn height; random actions ~ N(0, sigma) (0: stand). Returns (finite, the fraction of
    joint-steps whose velocity flips sign at more than 1 rad/s on both sides (the explicit PD's Nyquist chatter),
    the final base heights)."""
    spec = robot.go1_spec(inertia=inertia, armature=armature, integrator=integrator)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], contype=0,
                            conaffinity=robot.ROBOT_BIT, condim=3)
    m = spec.compile()
    rng = np.random.default_rng(seed)
    ms = rng.uniform(0.8, 1.2, size=(n, 2, 12))
    steps = int(round(seconds / robot.SIM_DT))
    qd = np.zeros((steps, n, 12))
    heights, finite = np.zeros(n), True
    for w in range(n):
        m.actuator_gainprm[:, 0] = ms[w, 0] * robot.KP
        m.actuator_biasprm[:, 1] = -ms[w, 0] * robot.KP
        m.actuator_biasprm[:, 2] = -ms[w, 1] * robot.KD
        d = mujoco.MjData(m)
        d.qpos[:] = robot.standing_qpos()
        action = np.zeros(12)
        for t in range(steps):
            if t % robot.DECIMATION == 0 and sigma > 0:
                action = np.clip(rng.normal(0.0, sigma, 12), -robot.ACTION_CLIP, robot.ACTION_CLIP)
            d.ctrl[:] = action * robot.ACTION_SCALE + robot.DEFAULT_JOINT_POS
            mujoco.mj_step(m, d)
            qd[t, w] = d.qvel[6:]
        finite &= bool(np.all(np.isfinite(d.qpos)))
        heights[w] = d.qpos[2]
    flips = (np.sign(qd[1:]) != np.sign(qd[:-1])) & (np.abs(qd[1:]) > 1.0) & (np.abs(qd[:-1]) > 1.0)
    return finite, float(flips.mean()), heights


def test_urdf_model_is_stable_with_its_armature_and_not_without() -> None:
    """The explicit ``-KD qdot`` at 5 ms needs armature with the URDF's legs: without it a standing Go1 chatters
    (joint velocities flipping sign every step) and sags; with ``URDF_JOINT_ARMATURE`` it stands still, and random
    actions flip joint velocities about as often as with Menagerie's model (measured over 64 worlds x 20 s:
    9.6% vs 8.8%; armature 0: 50%)."""
    finite, flips, heights = _chatter("urdf", None, 2.0, 0.0)
    assert finite and flips == 0.0 and np.all(np.abs(heights - 0.305) < 0.01), (flips, heights)
    finite, flips, _ = _chatter("urdf", None, 3.0, 1.0, seed=1)
    assert finite and flips < 0.14, flips
    finite, flips, heights = _chatter("urdf", 0.0, 2.0, 0.0)
    assert flips > 0.5 and heights.mean() < 0.27, (flips, heights)


def test_implicitfast_stands_the_armature_free_urdf_model() -> None:
    """With ``integrator="implicitfast"`` the damping term is implicit, so the original's armature-free URDF Go1
    stands still where the explicit (Euler) step chatters and sags (the test above: more than half of the
    joint-steps flip; here 0 on MuJoCo's soft contacts, 0.05% on the default stiffer ones, at the landing); random
    actions flip joint velocities less than Euler does without armature (measured over 8 worlds x 3 s: 15% against
    49%; with the armature 9.4%: the lighter legs reverse faster)."""
    finite, flips, heights = _chatter("urdf", 0.0, 2.0, 0.0, integrator="implicitfast")
    assert finite and flips < 0.001 and np.all(np.abs(heights - 0.305) < 0.01), (flips, heights)
    finite, flips, _ = _chatter("urdf", 0.0, 3.0, 1.0, seed=1, integrator="implicitfast")
    assert finite and flips < 0.25, flips


@pytest.mark.parametrize("joints", [{}, {"robot_armature": 0.0, "robot_integrator": "implicitfast"}],
                         ids=["armature", "original-joints"])
def test_env_runs_the_urdf_model(joints) -> None:
    """``ParkourEnv(robot_inertia="urdf")`` in MuJoCo Warp (CPU), with its armature or with the original's
    armature-free joints under ``implicitfast``: the compiled model is the URDF's, and random actions with domain
    randomization leave no world with a failed physics state."""
    terrain = synthetic_terrain(SyntheticConfig(columns=("flat", "box_jump_even"), num_rows=1))
    assert build_scene(terrain, representation="grid", robot_inertia="urdf").mjm.body_mass.sum() == pytest.approx(
        11.309932)
    env = ParkourEnv(terrain, 8, device="cpu", seed=0, robot_inertia="urdf", random_start_progress=False, **joints)
    assert env.scene.robot_inertia == "urdf"
    assert env.scene.robot_armature == joints.get("robot_armature", robot.URDF_JOINT_ARMATURE)
    np.testing.assert_array_equal(env.scene.mjm.dof_armature[6:], env.scene.robot_armature)
    assert float(env.scene.mjm.body_mass.sum()) == pytest.approx(11.309932)
    generator = torch.Generator().manual_seed(0)
    td = env.reset()
    max_qd = 0.0
    for _ in range(100):  # 2 s
        td["action"] = torch.randn(8, 12, generator=generator).clamp(-5.0, 5.0)
        _, td = env.step_and_maybe_reset(td)
        max_qd = max(max_qd, float(env.joint_vel.abs().max()))
    assert torch.isfinite(td["observation"]).all()
    assert env.pop_episode_stats()["unhealthy"].sum() == 0
    assert max_qd < 150.0, max_qd


def _standing_penetration(contact_timeconst: float | None) -> float:
    """MuJoCo C: a Go1 holding its default pose on a plane; mean foot penetration (m) over 1.0-1.5 s."""
    spec = robot.go1_spec(contact_timeconst=contact_timeconst)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], contype=0,
                            conaffinity=robot.ROBOT_BIT, condim=3)
    m = spec.compile()
    d = mujoco.MjData(m)
    d.qpos[:] = robot.standing_qpos()
    feet = [m.geom(f"{leg}_foot_sphere").id for leg in robot.LEGS]
    depth = []
    for t in range(int(round(1.5 / robot.SIM_DT))):
        d.ctrl[:] = robot.DEFAULT_JOINT_POS
        mujoco.mj_step(m, d)
        if t * robot.SIM_DT > 1.0:
            depth.append(robot.FOOT_RADIUS - d.geom_xpos[feet, 2])
    return float(np.mean(depth))


def test_contact_time_constant_choice_version_and_stiffness() -> None:
    """``contact_timeconst`` sets the solref of every robot collision geom (which has priority over the terrain, so
    it is the contact's): 0.01 s by default, MuJoCo's own 0.02 s with ``None`` (the model version of every stage
    before the stiffer default); a stiffer contact lets a standing Go1 sink less (measured 2026-11-28: 5.0 mm at
    0.02 s, 1.2 mm at 0.01 s: the depth goes as the square of the time constant); bad values get one error naming
    the parameter and its range."""
    soft, default = robot.go1_spec(contact_timeconst=None).compile(), robot.go1_spec().compile()
    colliding = default.geom_contype != 0
    assert int(colliding.sum()) == 4 * 4 + 2  # trunk, camera box; per leg hip, thigh, calf, foot
    np.testing.assert_array_equal(soft.geom_solref[colliding], np.tile([0.02, 1.0], (18, 1)))
    np.testing.assert_array_equal(default.geom_solref[colliding], np.tile([0.01, 1.0], (18, 1)))
    assert robot.model_version(contact_timeconst=None) == robot.MODEL_VERSION
    assert robot.model_version() == robot.model_version(contact_timeconst=0.01) == robot.MODEL_VERSION + "+contact-0.01"
    versions = {robot.model_version(*args) for args in (
        ("menagerie",), ("menagerie", None, "euler", None), ("menagerie", None, "euler", 0.015),
        ("urdf",), ("urdf", None, "euler", None))}
    assert len(versions) == 5 and all(robot.MODEL_VERSION in v for v in versions)
    soft_depth, stiff_depth = _standing_penetration(None), _standing_penetration(0.01)
    assert 0.003 < soft_depth < 0.008 and stiff_depth < 0.3 * soft_depth, (soft_depth, stiff_depth)
    for bad in (0.005, 0.06, "0.01", True):
        with pytest.raises(ValueError, match=r"^robot_contact_timeconst must be a number of seconds in \[0.01, 0.05\]"):
            robot.go1_spec(contact_timeconst=bad)
