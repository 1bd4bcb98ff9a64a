"""``robot_collision_pieces``: the Go1's boxes and long capsules as equal pieces, the same solids (MuJoCo C)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import torch

from mtbench.envs.parkour import robot


def _colliding(m: mujoco.MjModel) -> list[str]:
    return [m.geom(g).name for g in range(m.ngeom) if m.geom_contype[g]]


@pytest.mark.parametrize("pieces", [2, 3, 4])
def test_pieces_tile_each_shape_exactly(pieces: int) -> None:
    whole = robot.go1_spec().compile()
    cut = robot.go1_spec(collision_pieces=pieces).compile()
    # per leg: hip (short and thick: whole), thigh and calf (cut), foot sphere (whole); trunk and camera boxes cut
    assert len(_colliding(cut)) == 4 * (1 + 2 * pieces + 1) + 2 * pieces
    for name in ["trunk_box", "camera_box"] + [f"{leg}_{link}_capsule" for leg in robot.LEGS for link in ("thigh", "calf")]:
        g = whole.geom(name)
        parts = [cut.geom(f"{name}_{k}") for k in range(pieces)]
        assert all(p.bodyid == g.bodyid and p.type == g.type for p in parts)
        np.testing.assert_allclose([p.solref for p in parts], np.tile(g.solref, (pieces, 1)))
        np.testing.assert_allclose([p.friction for p in parts], np.tile(g.friction, (pieces, 1)))
        if g.type == mujoco.mjtGeom.mjGEOM_BOX:
            axis = int(np.argmax(g.size))
            sizes = np.array([p.size for p in parts])
            centres = np.array([p.pos for p in parts])
            # the pieces' lengths add up to the box's, they abut, and they cover it from end to end
            assert sizes[:, axis].sum() == pytest.approx(g.size[axis])
            np.testing.assert_allclose(np.delete(sizes, axis, 1), np.tile(np.delete(g.size, axis), (pieces, 1)))
            lows, highs = centres[:, axis] - sizes[:, axis], centres[:, axis] + sizes[:, axis]
            np.testing.assert_allclose(lows[1:], highs[:-1], atol=1e-12)
            assert lows[0] == pytest.approx(g.pos[axis] - g.size[axis])
            assert highs[-1] == pytest.approx(g.pos[axis] + g.size[axis])
            np.testing.assert_allclose(np.delete(centres, axis, 1), np.tile(np.delete(g.pos, axis), (pieces, 1)))
        else:
            # capsules of the same radius on consecutive, equal parts of the segment: the same solid
            assert all(p.size[0] == pytest.approx(g.size[0]) for p in parts)
            assert sum(p.size[1] for p in parts) == pytest.approx(g.size[1])
            axis = np.array([0.0, 0.0, 1.0])  # the thigh and calf segments run along the link's z
            ends = [(p.pos - p.size[1] * axis, p.pos + p.size[1] * axis) for p in parts]
            top, bottom = g.pos + g.size[1] * axis, g.pos - g.size[1] * axis
            chain = sorted(ends, key=lambda e: -e[1][2])
            np.testing.assert_allclose(chain[0][1], top, atol=1e-12)
            np.testing.assert_allclose(chain[-1][0], bottom, atol=1e-12)
            for upper, lower in zip(chain[:-1], chain[1:]):
                np.testing.assert_allclose(upper[0], lower[1], atol=1e-12)
    for name in [f"{leg}_hip_capsule" for leg in robot.LEGS] + [f"{leg}_foot_sphere" for leg in robot.LEGS]:
        np.testing.assert_array_equal(cut.geom(name).size, whole.geom(name).size)
    # massless shapes: the robot's mass and inertia do not change
    np.testing.assert_allclose(cut.body_mass, whole.body_mass)
    np.testing.assert_allclose(cut.body_inertia, whole.body_inertia)


def _ground_model(pieces: int) -> mujoco.MjModel:
    """The Go1 (``pieces`` per box and long capsule) over a flat 2 m x 2 m heightfield whose top is at z = 0."""
    spec = robot.go1_spec(collision_pieces=pieces)
    spec.add_hfield(name="ground", nrow=41, ncol=41, size=[1.0, 1.0, 0.1, 0.1], userdata=[0.0] * 41 * 41)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="ground", pos=[0.0, 0.0, -0.1], contype=0,
                            conaffinity=robot.ROBOT_BIT, condim=3)
    m = spec.compile()
    m.hfield_data[:] = 1.0
    return m


def _on_its_back() -> np.ndarray:
    qpos = robot.standing_qpos((0.0, 0.0, 0.3))
    qpos[3:7] = [0.0, 1.0, 0.0, 0.0]  # rolled over: the trunk's top faces the ground
    return qpos


def _upside_down_drop(pieces: int) -> tuple[np.ndarray, np.ndarray, int]:
    """MuJoCo C: the Go1 dropped on its back from 0.3 m onto a flat heightfield, legs holding the default pose:
    (trunk position, trunk quaternion) after 1.5 s and the most contacts of a step."""
    m = _ground_model(pieces)
    d = mujoco.MjData(m)
    d.qpos[:] = _on_its_back()
    most = 0
    for _ in range(int(round(1.5 / robot.SIM_DT))):
        d.ctrl[:] = robot.DEFAULT_JOINT_POS
        mujoco.mj_step(m, d)
        most = max(most, d.ncon)
    return d.qpos[:3].copy(), d.qpos[3:7].copy(), most


def test_a_cut_robot_rests_where_the_whole_one_does() -> None:
    """A Go1 dropped on its back onto a flat heightfield comes to rest on the camera box and the trunk's rear edge
    (pitched ~0.13 rad, trunk centre ~8 cm up) at the same height and attitude whether its trunk, camera box and leg
    capsules are whole or in 2 or 4 pieces (measured: 80.7 / 80.3 / 80.3 mm, up axes within 0.023 rad)."""
    heights, up = [], []
    for n in (1, 2, 4):
        pos, quat, _ = _upside_down_drop(n)
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, quat)
        heights.append(pos[2])
        up.append(mat.reshape(3, 3)[:, 2])
    assert 0.07 < heights[0] < 0.09 and up[0][2] < -0.98  # on its back, tilted onto the camera box
    for n, height, axis in zip((2, 4), heights[1:], up[1:]):
        assert height == pytest.approx(heights[0], abs=1e-3), n
        assert np.arccos(np.clip(np.dot(axis, up[0]), -1.0, 1.0)) < 0.05, n


def test_bad_collision_pieces_and_the_model_version() -> None:
    for bad in (0, 9, 2.0, "2", True):
        with pytest.raises(ValueError, match=r"^robot_collision_pieces must be an integer in \[1, 8\]"):
            robot.go1_spec(collision_pieces=bad)
    assert robot.model_version(collision_pieces=1) == robot.model_version()
    assert robot.model_version(collision_pieces=4) == robot.model_version() + "+pieces-4"
    assert robot.is_split(mujoco.mjtGeom.mjGEOM_BOX, [0.01, 0.02, 0.03])
    assert robot.is_split(mujoco.mjtGeom.mjGEOM_CAPSULE, [robot.CALF_RADIUS, 0.09])
    assert not robot.is_split(mujoco.mjtGeom.mjGEOM_CAPSULE, [robot.HIP_RADIUS, robot.HIP_HALF_LENGTH])
    assert not robot.is_split(mujoco.mjtGeom.mjGEOM_SPHERE, [robot.FOOT_RADIUS, 0.0])


def test_mujoco_warp_rests_a_cut_robot_where_a_whole_one_rests() -> None:
    """The same drop in MuJoCo Warp (CPU device), which keeps at most 4 contacts per robot-geom/heightfield pair: the
    cut robot (4 pieces) comes to rest where the whole one does in MuJoCo Warp and in MuJoCo C (measured: 80.2 mm
    in MuJoCo Warp for 1, 2 and 4 pieces; 80.7 / 80.3 / 80.3 mm in MuJoCo C)."""
    from mtbench.sim import WarpSim

    c_height = _upside_down_drop(1)[0][2]
    rest = []
    for pieces in (1, 4):
        m = _ground_model(pieces)
        pairs = int((m.geom_contype & robot.ROBOT_BIT).astype(bool).sum())
        sim = WarpSim(m, 1, "cpu", substeps=robot.DECIMATION, nconmax=4 * pairs, njmax=12 * pairs + 12,
                      use_graph=False)
        sim.qpos[:] = torch.as_tensor(_on_its_back(), dtype=torch.float32)
        sim.qvel.zero_()
        sim.kinematics()
        for _ in range(int(round(1.5 / (robot.SIM_DT * robot.DECIMATION)))):
            sim.ctrl[:] = torch.as_tensor(robot.DEFAULT_JOINT_POS, dtype=torch.float32)
            sim.step()
        assert not bool(sim.unhealthy().any())
        rest.append(float(sim.qpos[0, 2]))
    assert rest[0] == pytest.approx(c_height, abs=3e-3), (rest, c_height)
    assert rest[1] == pytest.approx(rest[0], abs=2e-3), rest
