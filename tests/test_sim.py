"""MuJoCo Warp simulation layer: agreement with MuJoCo C, masked resets, zero-copy views, health checks."""

from __future__ import annotations

import mujoco
import mujoco_warp as mjw
import numpy as np
import pytest
import torch

from mtbench.envs.metaworld.models import compiled_task
from mtbench.sim import FATAL_OVERFLOW, WarpSim


@pytest.fixture(scope="module")
def reach_model() -> mujoco.MjModel:
    return compiled_task("reach")[1]


def _mocap_path(t: int) -> np.ndarray:
    """A smooth hand trajectory that moves the arm through the workspace."""
    return np.array([0.1 * np.sin(0.05 * t), 0.6 + 0.1 * np.sin(0.03 * t), 0.2 - 0.1 * np.sin(0.04 * t)])


def test_warp_cpu_matches_mujoco_c_over_100_steps(reach_model: mujoco.MjModel) -> None:
    """Same model, same initial state, same mocap/actuator inputs: Warp (CPU, float32) tracks C (float64)."""
    m = reach_model
    sim = WarpSim(m, nworld=2, device="cpu", substeps=1)
    sim.reset(torch.ones(2, dtype=torch.bool))
    sim.kinematics()
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    hand0 = d.mocap_pos[0].copy()
    errors = []
    for t in range(100):
        target = hand0 + (_mocap_path(t) - _mocap_path(0))
        grip = 1.0 if (t // 25) % 2 else -1.0
        d.mocap_pos[0] = target
        d.ctrl[0] = grip
        sim.mocap_pos[:, 0] = torch.as_tensor(target, dtype=torch.float32)
        sim.ctrl[:, 0] = grip
        mujoco.mj_step(m, d)
        sim.step()
        errors.append(np.abs(sim.qpos[0].numpy() - d.qpos).max())
    # both worlds got identical inputs: identical results
    assert torch.equal(sim.qpos[0], sim.qpos[1])
    # float32 Warp vs float64 C over 100 steps of a moving, contact-free arm (measured: ~1e-4)
    print(f"max |qpos_warp - qpos_C| over 100 steps: {max(errors):.2e}")
    assert max(errors) < 2e-3, f"max |qpos_warp - qpos_C| = {max(errors):.2e}"
    # the trajectory is not trivial: the arm moved by a lot in both simulators
    assert np.abs(d.qpos - m.key("home").qpos).max() > 0.1


def test_masked_reset_only_touches_masked_worlds(reach_model: mujoco.MjModel) -> None:
    sim = WarpSim(reach_model, nworld=4, device="cpu", substeps=2)
    sim.reset(torch.ones(4, dtype=torch.bool))
    home = sim.qpos[0].clone()
    sim.mocap_pos[:, 0, 2] += 0.1
    for _ in range(20):
        sim.step()
    moved = sim.qpos.clone()
    assert (moved - home).abs().amax(-1).min() > 1e-3
    mask = torch.tensor([False, True, False, True])
    sim.reset(mask)
    assert torch.allclose(sim.qpos[1], home) and torch.allclose(sim.qpos[3], home)
    assert torch.equal(sim.qpos[0], moved[0]) and torch.equal(sim.qpos[2], moved[2])
    assert torch.all(sim.qvel[mask] == 0)
    # the reset also restores the keyframe's mocap target
    key_mocap = torch.as_tensor(reach_model.key("home").mpos, dtype=torch.float32)
    assert torch.allclose(sim.mocap_pos[1, 0], key_mocap)


def test_torch_views_are_zero_copy(reach_model: mujoco.MjModel) -> None:
    sim = WarpSim(reach_model, nworld=2, device="cpu", use_graph=False)
    assert sim.qpos.data_ptr() == sim.data.qpos.ptr
    sim.qpos[1, 0] = 0.123
    assert sim.data.qpos.numpy()[1, 0] == pytest.approx(0.123)


def test_unhealthy_flags_nan_and_runaway_worlds(reach_model: mujoco.MjModel) -> None:
    sim = WarpSim(reach_model, nworld=3, device="cpu")
    sim.reset(torch.ones(3, dtype=torch.bool))
    assert not sim.unhealthy().any()
    sim.qvel[1, 3] = float("nan")
    sim.qvel[2, 8] = 1e6
    assert sim.unhealthy().tolist() == [False, True, True]
    causes = sim.unhealthy_causes()
    assert causes["nonfinite"].tolist() == [False, True, False]
    assert causes["runaway"].tolist() == [False, False, True]  # (a NaN compares false: not a runaway)
    assert not causes["overflow"].any()
    sim.reset(torch.tensor([False, True, True]))
    assert not sim.unhealthy().any()


def test_an_overflow_outside_fatal_overflow_is_counted_not_unhealthy() -> None:
    """A ball dropped on a plane with a constraint buffer too small for its contact: the ``NEFC`` overflow makes
    the world unhealthy by default; declared not fatal (``fatal_overflow``) it does not, and :meth:`overflowed`
    reports it (and clears it when asked)."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])
    ball = spec.worldbody.add_body(pos=[0, 0, 0.1])
    ball.add_freejoint()
    ball.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.05, 0, 0], mass=1.0)
    m = spec.compile()
    nefc = int(mjw.OverflowType.NEFC)
    for fatal, expect in ((FATAL_OVERFLOW, True), (FATAL_OVERFLOW & ~nefc, False)):
        sim = WarpSim(m, nworld=2, device="cpu", njmax=1, fatal_overflow=fatal)  # a contact needs 4 rows
        for _ in range(100):  # 0.2 s: the ball reaches the plane after ~0.1 s
            sim.step()
        assert sim.unhealthy().tolist() == [expect, expect]
        assert sim.overflowed(nefc).tolist() == [True, True]
        assert sim.overflowed(nefc, clear=True).all() and not sim.overflowed(nefc).any()
        assert not sim.unhealthy().any()


def test_bad_arguments_are_rejected(reach_model: mujoco.MjModel) -> None:
    with pytest.raises(ValueError, match="nworld"):
        WarpSim(reach_model, nworld=0)
    with pytest.raises(ValueError, match="substeps"):
        WarpSim(reach_model, nworld=1, substeps=0)
    if not torch.cuda.is_available():
        with pytest.raises(RuntimeError, match="CUDA is not available"):
            WarpSim(reach_model, nworld=1, device="cuda")


_FIXTURE_XML = """
<mujoco><worldbody>
  <body name="fixture" pos="0.1 0.2 0.3" euler="0 0 90">
    <geom name="a" type="box" size="0.1 0.02 0.05" pos="0.2 0 0"/>
    <body name="inner" pos="0 0.1 0"><geom name="b" type="sphere" size="0.02" pos="0 0 0.1"/>
      <body name="moving" pos="0 0 0">
        <joint type="hinge" axis="0 0 1"/><geom name="c" type="sphere" size="0.01"/>
      </body>
    </body>
  </body>
  <geom name="floor" type="plane" size="1 1 0.1"/>
</worldbody></mujoco>
"""


def test_set_body_pos_moves_world_fixed_geoms_with_the_body() -> None:
    """MuJoCo Warp computes world-fixed geom positions once; moving their body per world must move them."""
    m = mujoco.MjModel.from_xml_string(_FIXTURE_XML)
    sim = WarpSim(m, nworld=2, device="cpu", batched_fields=("body_pos",))
    body, a, b, c, floor = (m.body("fixture").id, m.geom("a").id, m.geom("b").id, m.geom("c").id, m.geom("floor").id)
    before = sim.geom_xpos.clone()
    shift = torch.tensor([[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]])
    pos = sim.model_field("body_pos")[:, body] + shift
    sim.set_body_pos(body, pos, torch.tensor([True, False]))
    sim.step()  # kinematics moves the jointed child; the fixed geoms keep the written positions
    after = sim.geom_xpos
    for g in (a, b, c):  # fixed geoms of the subtree (a rotated 90 deg about z) and the jointed one all moved
        assert torch.allclose(after[0, g], before[0, g] + shift[0], atol=1e-5), g
    assert torch.allclose(after[0, a], torch.tensor([1.1, 2.4, 3.3]), atol=1e-5)
    assert torch.equal(after[1], before[1])  # masked-out world untouched
    assert torch.equal(after[:, floor], before[:, floor])  # geoms outside the subtree untouched
    with pytest.raises(ValueError, match="batched_fields"):
        WarpSim(m, nworld=1, device="cpu").set_body_pos(body, pos[:1], torch.tensor([True]))


def test_panda_fingers_are_damped_and_mesh_ridges_do_not_collide() -> None:
    from mtbench.envs.metaworld import robot

    m = robot.panda_spec("mesh").compile()
    for name in ("finger_joint1", "finger_joint2"):
        assert m.dof_damping[m.joint(name).dofadr[0]] == robot.FINGER_DAMPING
    finger_bodies = {m.body("left_finger").id, m.body("right_finger").id}
    boxes = [g for g in range(m.ngeom) if m.geom_bodyid[g] in finger_bodies and m.geom_type[g] == 6]
    small = [g for g in boxes if m.geom_size[g].max() < 0.005]
    assert len(boxes) == 10 and len(small) == 8
    assert all(m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0 for g in small)
    assert all(m.geom_contype[g] == robot.ROBOT_CONTYPE for g in set(boxes) - set(small))


def _rot(quat: np.ndarray) -> np.ndarray:
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, quat)
    return mat.reshape(3, 3)


def _colliding(m: mujoco.MjModel, body: str) -> list[int]:
    return [g for g in range(m.ngeom) if m.geom_bodyid[g] == m.body(body).id and m.geom_contype[g]]


def _outside_boxes(m: mujoco.MjModel, geoms: list[int], pts: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Distance of each point (body frame of the geoms, shifted by ``offset``) to the union of the boxes."""
    dist = np.full(len(pts), np.inf)
    for g in geoms:
        local = (pts + offset - m.geom_pos[g]) @ _rot(m.geom_quat[g])
        dist = np.minimum(dist, np.linalg.norm(np.maximum(np.abs(local) - m.geom_size[g], 0.0), axis=1))
    return dist


def test_primitive_hand_and_finger_boxes_cover_menagerie_collision_meshes() -> None:
    """The default hand/finger collision boxes enclose the convex hulls of Menagerie's collision meshes (the
    geometry MuJoCo collides) without inflating them, and keep the fingertip pad's grasping face."""
    from scipy.spatial import ConvexHull

    from mtbench.envs.metaworld import robot

    mesh, prim = robot.panda_spec("mesh").compile(), robot.panda_spec().compile()
    for body in ("hand", "left_finger", "right_finger"):
        assert {int(prim.geom_type[g]) for g in _colliding(prim, body)} == {int(mujoco.mjtGeom.mjGEOM_BOX)}

    def hull(body: str) -> ConvexHull:
        (g,) = [g for g in _colliding(mesh, body) if mesh.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH]
        adr, num = mesh.mesh_vertadr[mesh.geom_dataid[g]], mesh.mesh_vertnum[mesh.geom_dataid[g]]
        return ConvexHull(mesh.mesh_vert[adr:adr + num] @ _rot(mesh.geom_quat[g]).T + mesh.geom_pos[g])

    def box_volume(body: str) -> float:
        return sum(8.0 * float(np.prod(prim.geom_size[g])) for g in _colliding(prim, body))

    finger, hand = hull("left_finger"), hull("hand")
    finger_pts, hand_pts = finger.points[finger.vertices], hand.points[hand.vertices]
    # finger hull: inside the finger boxes, or (the 4 mm lip at its root) inside the hand box, at any opening
    for opening in (0.0, 0.04):
        offset = prim.body("left_finger").pos + np.array([0.0, opening, 0.0])
        dist = np.minimum(_outside_boxes(prim, _colliding(prim, "left_finger"), finger_pts, np.zeros(3)),
                          _outside_boxes(prim, _colliding(prim, "hand"), finger_pts, offset))
        assert dist.max() < 5e-4, dist.max()
    # hand hull: the housing (above the narrow cable ridge of the flange, z < -1 cm) within 7 mm of the box
    housing = hand_pts[hand_pts[:, 2] > -0.01]
    assert _outside_boxes(prim, _colliding(prim, "hand"), housing, np.zeros(3)).max() < 7e-3
    # no inflation: box volumes within 10% of the hull volumes
    assert box_volume("left_finger") == pytest.approx(finger.volume, rel=0.1)
    assert box_volume("hand") == pytest.approx(hand.volume, rel=0.1)
    # the grasping face of the fingertip is where Menagerie's pad box has it
    pad = [g for g in _colliding(mesh, "left_finger") if mesh.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    (tip,) = [g for g in _colliding(prim, "left_finger") if prim.geom(g).name.endswith("tip_box")]
    assert prim.geom_pos[tip][1] - prim.geom_size[tip][1] == pytest.approx(
        mesh.geom_pos[pad[0]][1] - mesh.geom_size[pad[0]][1], abs=1e-6)
    with pytest.raises(ValueError, match="primitive, mesh"):
        robot.panda_spec("capsules")


def test_table_top_collides_as_a_plane_at_the_table_surface() -> None:
    """The table's collision box is replaced by a plane at its top (primitive contacts instead of GJK/EPA): a
    puck dropped above the table comes to rest on the surface, as it did on the box (MuJoCo C)."""
    _, model = compiled_task("pick_place")
    table = model.body("tablelink").id
    colliding = [g for g in range(model.ngeom)
                 if model.geom_bodyid[g] == table and (model.geom_contype[g] or model.geom_conaffinity[g])]
    assert [int(model.geom_type[g]) for g in colliding] == [int(mujoco.mjtGeom.mjGEOM_PLANE)]
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    plane = colliding[0]
    surface_z = float(data.geom_xpos[plane][2])
    assert surface_z == pytest.approx(0.0, abs=1e-9)  # Meta-World's table top
    puck = model.geom("objGeom").id
    half_height = float(model.geom_size[puck][1])
    joint = model.body_jntadr[model.body("obj").id]
    adr, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
    data.qpos[adr:adr + 7] = [0.1, 0.75, surface_z + half_height + 0.05, 1.0, 0.0, 0.0, 0.0]
    for _ in range(int(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    assert float(data.geom_xpos[puck][2]) == pytest.approx(surface_z + half_height, abs=2e-3)
    assert np.abs(data.qvel[dof:dof + 6]).max() < 1e-2  # at rest


_BOX_ON_BOX_XML = """
<mujoco><option timestep="0.002"/><worldbody>
  <geom name="base" type="box" size="0.05 0.05 0.05" pos="0 0 0.05"/>
  <body name="top" pos="0 0 0.1495" euler="0 0 45"><freejoint/><geom name="top" type="box" size="0.05 0.05 0.05"/></body>
</worldbody></mujoco>
"""


def test_primitive_box_box_collider_matches_mujoco_c() -> None:
    """A box turned 45 degrees on another: their faces overlap in an octagon. MuJoCo C's box-box routine, and
    WarpSim's default ``box_box_collider="primitive"``, put a contact at each of its 8 corners (MuJoCo Warp's
    GJK/EPA default would give at most 4)."""
    m = mujoco.MjModel.from_xml_string(_BOX_ON_BOX_XML)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert d.ncon == 8
    sim = WarpSim(m, nworld=1, device="cpu", use_graph=False)
    sim.kinematics()
    import mujoco_warp as mjw
    import warp as wp

    mjw.collision(sim.model, sim.data)
    n = int(wp.to_torch(sim.data.nacon)[0])
    assert n == d.ncon
    warp_pos = wp.to_torch(sim.data.contact.pos)[:n].double().numpy()
    c_pos = np.array([d.contact[i].pos for i in range(d.ncon)])
    # same contact points (order may differ)
    dist = np.linalg.norm(warp_pos[:, None] - c_pos[None], axis=-1)
    assert dist.min(axis=1).max() < 1e-5
    assert np.allclose(sorted(wp.to_torch(sim.data.contact.dist)[:n].tolist()), sorted(d.contact.dist), atol=1e-6)
    with pytest.raises(ValueError, match="primitive, gjk"):
        WarpSim(m, nworld=1, device="cpu", box_box_collider="libccd")
