"""Parkour physics: the Go1's PD actuators, the terrain heightfields, and the WarpSim features the env uses
(per-body contact forces, per-world constants after domain randomization), against MuJoCo C and hand computations."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import torch

from cpu_runs import one_torch_thread
from mtbench.envs.parkour import domain_rand, robot
from mtbench.envs.parkour.scene import build_scene
from mtbench.sim import WarpSim
from parkour_synthetic import SyntheticConfig, synthetic_terrain


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    """Tiny tensors: one torch thread avoids thread-pool wake-ups that dominate on a busy 2-core CPU."""
    with one_torch_thread():
        yield


def _pd_torque(q_target, q, qdot, ms0=1.0, ms1=1.0):
    """The original's ``_compute_torques`` (control_type P) followed by the +-33.5 N m clip."""
    return np.clip(ms0 * 50.0 * (q_target - q) - ms1 * 3.0 * qdot, -33.5, 33.5)


@pytest.fixture(scope="module")
def terrain():
    return synthetic_terrain(SyntheticConfig(columns=("flat", "box_jump_even"), num_rows=2))


@pytest.fixture(scope="module")
def scene(terrain):
    return build_scene(terrain, "legs", "grid")


def _random_state(rng: np.random.Generator, base=(1.0, 2.0, 0.6)):
    qpos = robot.standing_qpos(base)
    qpos[7:] += rng.uniform(-0.4, 0.4, 12)
    qvel = np.zeros(18)
    qvel[6:] = rng.uniform(-8.0, 8.0, 12)
    ctrl = robot.DEFAULT_JOINT_POS + rng.uniform(-1.5, 1.5, 12)
    return qpos, qvel, ctrl


def test_robot_joint_order_and_collision_sets() -> None:
    m = robot.go1_spec("legs").compile()
    names = [m.joint(m.actuator_trnid[i, 0]).name for i in range(m.nu)]
    assert names == list(robot.JOINT_NAMES)
    assert [m.jnt_qposadr[m.joint(n).id] for n in robot.JOINT_NAMES] == list(range(7, 19))
    for choice, expected in (("feet", 4), ("legs", 12), ("all", 18)):
        mc = robot.go1_spec(choice).compile()
        colliding = [mc.geom(g).name for g in range(mc.ngeom) if mc.geom_contype[g]]
        assert len(colliding) == expected, (choice, colliding)
        # never with itself: no robot geom has a conaffinity
        assert not np.any(mc.geom_conaffinity[mc.geom_bodyid != 0])
    # "all" has the URDF's camera-module box on the trunk: imu_link's collision box (.05 x .11 x .17 at
    # imu_link + (0.28, 0.06659, 0.0325), imu_joint at trunk + (-0.01592, -0.06659, -0.00617)), merged into the trunk
    camera = mc.geom("camera_box")
    assert camera.bodyid == mc.body(robot.BASE_BODY).id and camera.type == mujoco.mjtGeom.mjGEOM_BOX
    np.testing.assert_allclose(camera.pos, np.add((-0.01592, -0.06659, -0.00617), (0.28, 0.06659, 0.0325)), atol=1e-9)
    np.testing.assert_allclose(camera.size, np.array([0.05, 0.11, 0.17]) / 2)
    trunk = mc.geom("trunk_box")
    assert camera.pos[0] + camera.size[0] - (trunk.pos[0] + trunk.size[0]) == pytest.approx(0.10098)  # 10 cm ahead
    # the joint limits are the original URDF's (hip +-46 deg, thigh -60..240 deg, calf -154.5..-52.5 deg)
    mc = robot.go1_spec().compile()
    for name in robot.JOINT_NAMES:
        lo, hi = mc.joint(name).range
        expected = {"hip": (-46.0, 46.0), "thigh": (-60.0, 240.0), "calf": (-154.5, -52.5)}[name.split("_")[1]]
        assert mc.jnt_limited[mc.joint(name).id]
        np.testing.assert_allclose(np.degrees([lo, hi]), expected, atol=0.01)
    # the feet are massless bodies welded to the calves: the robot keeps Menagerie's mass
    menagerie = mujoco.MjModel.from_xml_path(str(robot.menagerie_dir("unitree_go1") / "go1.xml"))
    assert m.body_mass.sum() == pytest.approx(menagerie.body_mass.sum())
    assert all(m.body_mass[m.body(f).id] == 0 for f in robot.FOOT_BODIES)
    with pytest.raises(ValueError, match="valid choices"):
        robot.go1_spec("knees")


def test_pd_torques_match_hand_computation_in_mujoco_c(scene) -> None:
    m = scene.mjm
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for _ in range(5):
        qpos, qvel, ctrl = _random_state(rng)
        d.qpos[:], d.qvel[:], d.ctrl[:] = qpos, qvel, ctrl
        mujoco.mj_step(m, d)  # the step's torques come from the state it started from
        expected = _pd_torque(ctrl, qpos[7:], qvel[6:])
        np.testing.assert_allclose(d.actuator_force, expected, atol=1e-9)
        np.testing.assert_allclose(d.qfrc_actuator[6:], expected, atol=1e-9)
    assert np.any(np.abs(expected) == 33.5)  # the clip was exercised
    # mj_step integrates exactly these torques (no joint damping or friction besides the PD)
    assert np.all(m.dof_damping[6:] == 0) and np.all(m.dof_frictionloss[6:] == 0)


def _step_random_states(sim: WarpSim, seed: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Put each of ``sim``'s worlds in a random airborne state (``_random_state``), take one physics step and return
    the ``(qpos, qvel, ctrl)`` it started from."""
    rng = np.random.default_rng(seed)
    states = [_random_state(rng) for _ in range(sim.qpos.shape[0])]
    for k, field in enumerate((sim.qpos, sim.qvel, sim.ctrl)):
        field.copy_(torch.tensor(np.stack([s[k] for s in states]), dtype=torch.float32))
    sim.kinematics()
    sim.step()
    return states


def test_pd_torques_with_motor_strengths_in_warp_and_c(scene) -> None:
    m = scene.mjm
    n = 3
    sim = WarpSim(m, n, "cpu", substeps=1, nconmax=48, njmax=160, batched_fields=domain_rand.BATCHED_FIELDS,
                  use_graph=False)
    params = domain_rand.sample(n, torch.Generator().manual_seed(1), "cpu")
    domain_rand.apply(sim, m, params)
    states = _step_random_states(sim, 2)  # actuator_force is computed from the state at the start of the step
    warp_force = sim.data.actuator_force.numpy()
    ms = params.motor_strength.numpy()
    for w, (qpos, qvel, ctrl) in enumerate(states):
        expected = _pd_torque(ctrl, qpos[7:], qvel[6:], ms[0, w], ms[1, w])
        np.testing.assert_allclose(warp_force[w], expected, atol=2e-3)  # float32
        # MuJoCo C with the same gains
        mc = scene.mjm.__copy__()
        mc.actuator_gainprm[:, 0] = ms[0, w] * robot.KP
        mc.actuator_biasprm[:, 1] = -ms[0, w] * robot.KP
        mc.actuator_biasprm[:, 2] = -ms[1, w] * robot.KD
        d = mujoco.MjData(mc)
        d.qpos[:], d.qvel[:], d.ctrl[:] = qpos, qvel, ctrl
        mujoco.mj_step(mc, d)
        np.testing.assert_allclose(d.actuator_force, expected, atol=1e-5)
    assert not np.allclose(ms[0, 0], ms[0, 1])


def test_implicitfast_step_in_warp_matches_mujoco_c(terrain) -> None:
    """``robot_integrator="implicitfast"`` with the armature-free URDF model (the original's joints): MuJoCo Warp's
    step (implicit actuator damping, no derivative for clamped torques) gives MuJoCo C's velocities, for airborne
    robots with random joint states (some torques clamped), and differs from the Euler step of the same model."""
    velocities = {}
    for integrator in ("implicitfast", "euler"):
        scene = build_scene(terrain, "legs", "grid", robot_inertia="urdf", robot_armature=0.0,
                            robot_integrator=integrator)
        assert scene.robot_armature == 0.0 and scene.robot_integrator == integrator
        m, n = scene.mjm, 3
        sim = WarpSim(m, n, "cpu", substeps=1, nconmax=48, njmax=160, use_graph=False)
        states = _step_random_states(sim, 5)
        clamped = 0
        for w, (qpos, qvel, ctrl) in enumerate(states):
            d = mujoco.MjData(m)
            d.qpos[:], d.qvel[:], d.ctrl[:] = qpos, qvel, ctrl
            mujoco.mj_step(m, d)
            clamped += int(np.sum(np.abs(d.actuator_force) >= robot.TORQUE_LIMIT - 1e-6))
            np.testing.assert_allclose(sim.qvel[w].numpy(), d.qvel, atol=5e-3, rtol=1e-3)
        assert 0 < clamped < 3 * 12  # both clamped and unclamped joints took part
        velocities[integrator] = sim.qvel.numpy().copy()
    assert np.abs(velocities["implicitfast"] - velocities["euler"]).max() > 0.1


def test_heightfield_holds_the_terrain_heights(terrain, scene) -> None:
    m = scene.mjm
    nx, ny = terrain.heights.shape
    assert (m.hfield_ncol[0], m.hfield_nrow[0]) == (nx, ny)
    data = m.hfield_data[: nx * ny].reshape(ny, nx).T
    g = scene.hfield_geom
    z = m.geom_pos[g, 2] + data * m.hfield_size[0, 2]
    np.testing.assert_allclose(z, terrain.heights, atol=1e-6)
    # vertex (0, 0) sits at world (-border, -border)
    assert m.geom_pos[g, 0] - m.hfield_size[0, 0] == pytest.approx(-terrain.border)
    assert m.geom_pos[g, 1] - m.hfield_size[0, 1] == pytest.approx(-terrain.border)
    # a ray straight down onto the box step of tile (1, 1) hits its top (0.4 m); onto the flat tile: 0
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    geomid = np.zeros(1, dtype=np.int32)
    for x, y, h in ((8.0 + 4.0, 6.0, 0.4), (8.0 + 4.0, 2.0, 0.0)):
        dist = mujoco.mj_ray(m, d, np.array([x, y, 2.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geomid)
        assert 2.0 - dist == pytest.approx(h, abs=1e-5)


def test_tiles_representation_cuts_each_tile_from_the_grid(terrain) -> None:
    tiles = build_scene(terrain, "legs", "tiles", tile_margin=1.0)
    m = tiles.mjm
    assert m.nhfield == terrain.tile_origins.shape[0] * terrain.tile_origins.shape[1]
    hs = terrain.config.horizontal_scale
    g = tiles.hfield_geom
    for i in range(2):
        for j in range(2):
            k = tiles.tile_hfield[i, j]
            nx, ny = m.hfield_ncol[k], m.hfield_nrow[k]
            data = m.hfield_data[m.hfield_adr[k]: m.hfield_adr[k] + nx * ny].reshape(ny, nx).T
            z = m.geom_pos[g, 2] + data * m.hfield_size[k, 2]
            # tile frame point (x, y) is world (x, y) + tile_offset: compare vertices with the grid heights
            x0 = m.geom_pos[g, 0] - m.hfield_size[k, 0] + tiles.tile_offset[i, j, 0]
            y0 = m.geom_pos[g, 1] - m.hfield_size[k, 1] + tiles.tile_offset[i, j, 1]
            a0 = int(round((x0 + terrain.border) / hs))
            b0 = int(round((y0 + terrain.border) / hs))
            np.testing.assert_allclose(z, terrain.heights[a0: a0 + nx, b0: b0 + ny], atol=1e-6)
    assert tiles.tile_offset[1, 1].tolist() == [8.0, 4.0, 0.0]
    with pytest.raises(ValueError, match="tile_margin"):
        build_scene(terrain, "legs", "tiles", tile_margin=5.0)
    with pytest.raises(ValueError, match="valid choices"):
        build_scene(terrain, "legs", "voxels")


def test_tiles_keep_robots_near_their_heightfield_centre() -> None:
    """The tiles scene keeps every point of a tile (and its margin) within 11 m of the heightfield centre, where
    MuJoCo Warp's heightfield contacts are sound; the one-grid heightfield of the full 10 x 21 grid does not."""
    from mtbench.envs.parkour.terrain import TerrainConfig, generate_terrain

    terrain = generate_terrain(TerrainConfig(num_rows=2, columns=("flat", "balance_beam", "flat")))
    tiles = build_scene(terrain, "feet", "tiles")
    m, g, k = tiles.mjm, tiles.hfield_geom, 0
    corner = np.array([m.hfield_size[k, 0], m.hfield_size[k, 1]])
    assert np.linalg.norm(corner) < 11.0
    # a tile's physics frame: x in [0, 18], y in [0, 4] (plus the margin) around the heightfield centre
    centre = m.geom_pos[g, :2]
    for x, y in ((-1.0, -1.0), (19.0, 5.0), (1.0, 2.0)):
        assert np.linalg.norm(np.array([x, y]) - centre) < 11.0
    full = generate_terrain(TerrainConfig())
    extent = 0.5 * np.array(full.heights.shape) * full.config.horizontal_scale
    assert np.linalg.norm(extent) > 100.0  # "grid": tiles up to ~100 m from the centre


def test_heightfield_sphere_contacts_near_the_centre_agree_with_mujoco_c() -> None:
    """Spheres (the Go1's foot radius) 1 cm below grid vertices of a tile-sized heightfield with +-2 cm roughness:
    the deepest contact of MuJoCo Warp is within 4 cm of MuJoCo C's (measured up to 3.6 cm: the two heightfield
    colliders differ), never metres off."""
    import mujoco_warp as mjw
    import warp as wp

    hs, nx, ny, n = 0.05, 401, 121, 64
    rng = np.random.default_rng(0)
    h = rng.integers(-4, 5, size=(nx, ny)) * 0.005
    rx, ry = (nx - 1) * hs / 2, (ny - 1) * hs / 2
    spec = mujoco.MjSpec()
    spec.add_hfield(name="h", nrow=ny, ncol=nx, size=[rx, ry, float(h.max() - h.min()), 1.0],
                    userdata=np.zeros(nx * ny).tolist())
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="h", pos=[0, 0, float(h.min())])
    body = spec.worldbody.add_body()
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[robot.FOOT_RADIUS, 0, 0])
    m = spec.compile()
    m.hfield_data[:] = ((h.T - h.min()) / (h.max() - h.min())).astype(np.float32).ravel()
    a, b = rng.integers(10, nx - 10, n), rng.integers(10, ny - 10, n)  # above grid vertices
    px, py = a * hs - rx, b * hs - ry
    qpos = np.zeros((n, 7))
    qpos[:, 0], qpos[:, 1], qpos[:, 2], qpos[:, 3] = px, py, h[a, b] + robot.FOOT_RADIUS - 0.01, 1.0
    d = mujoco.MjData(m)
    c_min = np.zeros(n)
    for i in range(n):
        d.qpos[:] = qpos[i]
        mujoco.mj_forward(m, d)
        c_min[i] = min(d.contact[j].dist for j in range(d.ncon))
    sim = WarpSim(m, n, "cpu", nconmax=8, njmax=32, use_graph=False)
    sim.qpos.copy_(torch.tensor(qpos, dtype=torch.float32))
    with wp.ScopedDevice("cpu"):
        mjw.forward(sim.model, sim.data)
    count = int(sim.data.nacon.numpy()[0])
    w_min = np.zeros(n)
    np.minimum.at(w_min, sim.data.contact.worldid.numpy()[:count], sim.data.contact.dist.numpy()[:count])
    assert np.all(c_min < 0) and np.all(w_min < 0)
    assert np.abs(w_min - c_min).max() < 0.04


def test_body_contact_forces_match_mujoco_c(scene) -> None:
    """WarpSim(contact_forces=True): net contact force per body after a step = MuJoCo C's cfrc_ext after
    mj_rnePostConstraint, for a Go1 standing on the heightfield."""
    m = scene.mjm
    sim = WarpSim(m, 2, "cpu", substeps=1, nconmax=48, njmax=160, contact_forces=True)
    d = mujoco.MjData(m)
    d.qpos[:] = robot.standing_qpos((1.0, 2.0, 0.32))
    d.ctrl[:] = robot.DEFAULT_JOINT_POS
    sim.qpos.copy_(torch.tensor(d.qpos, dtype=torch.float32))
    sim.ctrl.copy_(torch.tensor(d.ctrl, dtype=torch.float32))
    sim.kinematics()
    for _ in range(100):
        mujoco.mj_step(m, d)
        sim.step()
    mujoco.mj_rnePostConstraint(m, d)
    feet = [m.body(b).id for b in robot.FOOT_BODIES]
    c_force = d.cfrc_ext[feet, 3:]
    w_force = sim.body_contact_force[0, feet].numpy()
    # standing: the feet carry the robot's weight; per foot within a few newtons of MuJoCo C (float32, contacts
    # of the heightfield collider differ in number: at most 4 per pair in MuJoCo Warp)
    weight = m.body_mass.sum() * 9.81
    assert c_force[:, 2].sum() == pytest.approx(weight, rel=0.05)
    assert w_force[:, 2].sum() == pytest.approx(weight, rel=0.05)
    np.testing.assert_allclose(w_force, c_force, atol=3.0)
    # nothing else touches the ground
    others = [b for b in range(1, m.nbody) if b not in feet]
    assert np.abs(sim.body_contact_force[:, others].numpy()).max() < 1e-6
    with pytest.raises(ValueError, match="contact_forces=True"):
        WarpSim(m, 1, "cpu", use_graph=False).body_contact_force


def test_set_const_gives_per_world_constants_like_mujoco_c(scene) -> None:
    """Per-world trunk mass / CoM through batched fields + WarpSim.set_const = MuJoCo C's mj_setConst."""
    m = scene.mjm
    n = 2
    sim = WarpSim(m, n, "cpu", batched_fields=domain_rand.BATCHED_FIELDS, use_graph=False)
    params = domain_rand.sample(n, torch.Generator().manual_seed(3), "cpu")
    # batched fields start as copies of the model's values
    assert torch.allclose(sim.model_field("body_mass"), torch.tensor(m.body_mass, dtype=torch.float32).expand(n, -1))
    domain_rand.apply(sim, m, params)
    trunk = m.body(robot.BASE_BODY).id
    for w in range(n):
        mc = m.__copy__()
        mc.body_mass[trunk] += float(params.added_mass[w])
        mc.body_inertia[trunk] *= mc.body_mass[trunk] / m.body_mass[trunk]
        mc.body_ipos[trunk] += params.com_offset[w].double().numpy()
        d = mujoco.MjData(mc)
        mujoco.mj_setConst(mc, d)
        np.testing.assert_allclose(sim.model_field("body_subtreemass")[w].numpy(), mc.body_subtreemass, rtol=1e-5)
        np.testing.assert_allclose(sim.model_field("dof_invweight0")[w].numpy(), mc.dof_invweight0, rtol=2e-3)
        np.testing.assert_allclose(sim.model_field("body_invweight0")[w].numpy(), mc.body_invweight0, rtol=2e-3,
                                   atol=1e-6)
    assert sim.model_field("body_subtreemass")[0, 1] != sim.model_field("body_subtreemass")[1, 1]


def test_trunk_touches_the_terrain_by_default(terrain) -> None:
    """The default collision set is the original's (every robot geom touches the terrain): a Go1 dropped upside
    down comes to rest on its trunk box and the camera-module box above its front (base height between the trunk
    box's half height and the camera box's top, 0.111 m above the trunk's origin). With ``"legs"`` the box passes
    into the ground until the thighs catch the robot; policies trained that way crawl with the trunk inside the
    terrain (docs/parkour.md)."""
    rest = {}
    for choice in (None, "legs"):
        scene = build_scene(terrain, representation="grid") if choice is None else build_scene(terrain, choice, "grid")
        m = scene.mjm
        d = mujoco.MjData(m)
        d.qpos[:] = robot.standing_qpos((1.0, 2.0, 0.25))
        d.qpos[3:7] = (0.0, 1.0, 0.0, 0.0)  # roll pi: upside down
        d.ctrl[:] = robot.DEFAULT_JOINT_POS
        for _ in range(150):  # 0.75 s
            mujoco.mj_step(m, d)
        rest[choice] = float(d.qpos[2])
    box = mujoco.mjtGeom.mjGEOM_BOX
    trunk = [g for g in range(m.ngeom) if m.geom_bodyid[g] == m.body("trunk").id and m.geom_type[g] == box]
    half_height = float(m.geom_size[trunk[0], 2])
    camera_top = robot.CAMERA_BOX_POS[2] + robot.CAMERA_BOX_HALF_SIZE[2]
    assert half_height - 0.01 < rest[None] < camera_top + 0.01, (rest, half_height)
    assert rest["legs"] < half_height - 0.03, (rest, half_height)


def _limit_overshoot(solref: tuple[float, ...] | None = None, solimp: tuple[float, ...] | None = None) -> dict:
    """Largest excursion (rad) past the upper limit of the FR hip and FR calf when their PD targets are 5 rad beyond
    the limit and they start at the opposite limit (base fixed in the air, 1 s of MuJoCo C), and where they end."""
    spec = robot.go1_spec()
    for joint in list(spec.joints):
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            spec.delete(joint)
        elif solref is not None:
            joint.solref_limit, joint.solimp_limit = list(solref), list(solimp)
    m = spec.compile()
    d = mujoco.MjData(m)
    hip, calf = m.joint("FR_hip_joint"), m.joint("FR_calf_joint")
    d.qpos[:] = robot.DEFAULT_JOINT_POS
    d.qpos[hip.qposadr[0]], d.qpos[calf.qposadr[0]] = hip.range[0], calf.range[0]
    target = robot.DEFAULT_JOINT_POS.copy()
    target[0], target[2] = hip.range[1] + 5.0, calf.range[1] + 5.0
    worst = {"hip": 0.0, "calf": 0.0}
    for _ in range(200):  # 1 s
        d.ctrl[:] = target
        mujoco.mj_step(m, d)
        worst["hip"] = max(worst["hip"], float(d.qpos[hip.qposadr[0]] - hip.range[1]))
        worst["calf"] = max(worst["calf"], float(d.qpos[calf.qposadr[0]] - calf.range[1]))
    worst["hip_end"] = float(d.qpos[hip.qposadr[0]] - hip.range[1])
    worst["calf_end"] = float(d.qpos[calf.qposadr[0]] - calf.range[1])
    return worst


def test_joint_limits_are_stiff() -> None:
    """IsaacGym enforces the URDF limits as hard constraints. A hip and a calf swung into their limits at the full
    33.5 N m stop within 0.12 / 0.3 rad of them (MuJoCo's default soft limits let them through by 0.26 / 0.56 rad,
    and trained policies then splayed their legs 0.2-0.5 rad past the hip range); held there, they settle at the
    limit."""
    m = robot.go1_spec().compile()
    hinge = m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE
    np.testing.assert_allclose(m.jnt_solref[hinge], np.tile(robot.JOINT_LIMIT_SOLREF, (12, 1)))
    np.testing.assert_allclose(m.jnt_solimp[hinge], np.tile(robot.JOINT_LIMIT_SOLIMP, (12, 1)))
    stiff = _limit_overshoot()
    soft = _limit_overshoot((0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0))  # MuJoCo's defaults
    assert stiff["hip"] < 0.12 and stiff["calf"] < 0.3, stiff
    assert abs(stiff["hip_end"]) < 0.01 and abs(stiff["calf_end"]) < 0.01, stiff
    assert soft["hip"] > 0.2 and soft["calf"] > 0.45, soft
