"""The Parkour env on a tiny synthetic grid (CPU): waypoints and progress, observation layout, termination,
rewards, domain randomization, curriculum, statistics, failed-physics resets, checkpoints, the settings."""

from __future__ import annotations

import math

from types import SimpleNamespace

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation
from torchrl.envs.utils import check_env_specs

from cpu_runs import one_torch_thread
from mtbench.envs import make_env
from mtbench.envs.parkour import curriculum as cl
from mtbench.envs.parkour import robot
from mtbench.envs.parkour.env import END_REASONS, ParkourEnv
from mtbench.envs.parkour.height_scan import SCAN_X, SCAN_Y
from mtbench.envs.parkour.observation import GROUPS, OBS_DIM, SLICES, STATE_DIM, scandots
from mtbench.envs.parkour.rewards import (REWARD_SCALES, collision, compute_reward, energy_cost,
                                          tracking_goal_vel, tracking_yaw)
from mtbench.envs.parkour.terrains import TERRAIN_NAMES
from mtbench.sim import FATAL_OVERFLOW, HFIELD_OVERFLOW
from parkour_synthetic import SyntheticConfig, synthetic_terrain

FLAT = TERRAIN_NAMES.index("flat")
BOX = TERRAIN_NAMES.index("box_jump_even")


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    """Tiny tensors: one torch thread avoids thread-pool wake-ups that dominate on a busy 2-core CPU."""
    with one_torch_thread():
        yield


def _env(columns=("flat",), num_rows=2, n=2, **kw) -> ParkourEnv:
    kw.setdefault("random_start_progress", False)
    kw.setdefault("push_robots", False)
    terrain = synthetic_terrain(SyntheticConfig(columns=columns, num_rows=num_rows))
    return ParkourEnv(terrain, n, device="cpu", seed=kw.pop("seed", 0), **kw)


def _teleport(env: ParkourEnv, xyz: torch.Tensor, quat: torch.Tensor | None = None) -> None:
    """Put every world's base at world position ``xyz`` [N, 3] (its tile's physics frame), at rest."""
    n = env.batch_size[0]
    env.sim.qpos[:, 0:3] = xyz - env.world_offset
    env.sim.qpos[:, 3:7] = torch.tensor([1.0, 0.0, 0.0, 0.0]) if quat is None else quat
    env.sim.qpos[:, 7:] = env.q_default
    env.sim.qvel.zero_()
    env.sim.kinematics()
    assert n == xyz.shape[0]


def _ends(stats, task: int) -> dict[str, int]:
    """The non-zero ``end_<reason>`` counts of ``task`` in ``pop_episode_stats()``; they sum to its episodes."""
    counts = {r: int(stats[f"end_{r}"][task]) for r in END_REASONS}
    assert sum(counts.values()) == int(stats["episodes"][task])
    return {r: c for r, c in counts.items() if c}


def _step(env: ParkourEnv, td, action: torch.Tensor | None = None):
    td["action"] = torch.zeros(env.batch_size[0], 12) if action is None else action
    out, td = env.step_and_maybe_reset(td)
    return out["next"], td


def test_waypoints_progress_statistics_and_curriculum_on_a_scripted_path() -> None:
    """Teleport world 0 along the centre line through its 8 goals (0.6 m apart from x = 1.5) and world 1 along a
    parallel line 0.35 m to the side: a goal counts after 2 steps within 0.3 m, all 8 end the episode as a
    time-out with progress 1, and the curriculum moves world 0 one row up and onto that row's tile."""
    env = _env(num_rows=3, curriculum=True)
    env.level.zero_()
    td = env.reset()
    y = 2.0  # centre line of column 0
    advanced_at, last = [], 0
    for t in range(200):
        x = 1.02 + 0.05 * t
        _teleport(env, torch.tensor([[x, y, 0.42], [x, y + 0.35, 0.42]]))
        nxt, td = _step(env, td)
        if nxt["done"][0]:
            break
        if int(env.cur_goal_idx[0]) != last:
            advanced_at.append(t)
            last = int(env.cur_goal_idx[0])
    # goal k is entered at x > 1.2 + 0.6k (t = 4 + 12k) and counted one step later
    assert advanced_at == [5 + 12 * k for k in range(7)]
    assert t == 5 + 12 * 7
    assert bool(nxt["truncated"][0]) and not bool(nxt["terminated"][0])
    assert not bool(nxt["done"][1]) and int(env.cur_goal_idx[1]) == 0
    stats = env.pop_episode_stats()
    assert stats["episodes"][FLAT] == 1 and stats["success"][FLAT] == 1.0
    assert stats["length"][FLAT] == t + 1
    assert _ends(stats, FLAT) == {"goals": 1}  # ended by reaching every goal
    assert stats["terrain_level"][FLAT] == 0 and stats["max_terrain_level"][FLAT] == 0
    assert stats["max_terrain_level"].sum() == 0 - (len(TERRAIN_NAMES) - 1)  # -1 for tasks without episodes
    # curriculum: 8 goals >= 0.8 * 8: one row up, and the new episode starts on row 1's tile (x = 8 + 1), whose
    # heightfield world 0 now simulates, in that tile's frame
    assert int(env.level[0]) == 1
    assert env.base_pos[0, 0] == pytest.approx(8.0 + 1.0, abs=1e-4)
    assert env.sim.qpos[0, 0] == pytest.approx(1.0, abs=1e-4) and env.world_offset[0, 0] == 8.0
    geom_dataid = env.sim.model_field("geom_dataid")[:, env.scene.hfield_geom]
    assert geom_dataid.tolist() == [int(env.scene.tile_hfield[1, 0]), int(env.scene.tile_hfield[0, 0])]
    assert int(env.cur_goal_idx[0]) == 0 and int(env.progress[0]) == 0


def test_observation_layout_matches_the_state_it_encodes() -> None:
    assert OBS_DIM == 233 and STATE_DIM == 212
    assert {k: v.stop - v.start for k, v in GROUPS.items()} == {
        "proprio": 48, "scandots": 132, "priv_explicit": 3, "priv_latent": 29, "task_one_hot": 21}
    env = _env(columns=("flat", "box_jump_even"), num_rows=1, n=2, seed=3)
    td = env.reset()
    action = torch.full((2, 12), 0.3)
    action[1, 0] = 7.0  # beyond the clip: observed as given, applied as 5
    for _ in range(10):  # the 10th global step refreshes the yaw deltas and scandots (and the feet are down)
        nxt, td = _step(env, td, action)
    assert not nxt["done"].any()
    obs = td["observation"]
    assert obs.shape == (2, 233)
    qpos, qvel = env.sim.qpos.double(), env.sim.qvel.double()
    pos = qpos[:, :3] + env.world_offset.double()  # world position (physics runs in each tile's frame)
    assert torch.equal(env.world_offset[:, :2], torch.tensor([[0.0, 0.0], [0.0, 4.0]]))
    o = {k: obs[:, s].double() for k, s in SLICES.items()}
    rot = Rotation.from_quat(qpos[:, [4, 5, 6, 3]].numpy())  # scipy: x, y, z, w
    yaw, pitch, roll = torch.tensor(rot.as_euler("ZYX")).T
    torch.testing.assert_close(o["base_ang_vel"], qvel[:, 3:6] * 0.25, atol=1e-6, rtol=0)
    torch.testing.assert_close(o["roll_pitch"], torch.stack([roll, pitch], -1), atol=1e-5, rtol=0)
    goal = env.goals[:, 0, :2].double()  # still heading for goal 0
    target_yaw = torch.atan2(goal[:, 1] - pos[:, 1], goal[:, 0] - pos[:, 0])
    torch.testing.assert_close(o["delta_yaw"][:, 0], target_yaw - yaw, atol=1e-5, rtol=0)
    next_goal = env.goals[:, 1, :2].double()
    next_yaw = torch.atan2(next_goal[:, 1] - pos[:, 1], next_goal[:, 0] - pos[:, 0])
    torch.testing.assert_close(o["delta_next_yaw"][:, 0], next_yaw - yaw, atol=1e-5, rtol=0)
    assert torch.all((o["command"] >= 0.3) & (o["command"] <= 0.8))
    torch.testing.assert_close(o["joint_pos"], qpos[:, 7:] - torch.tensor(robot.DEFAULT_JOINT_POS), atol=1e-6,
                               rtol=0)
    torch.testing.assert_close(o["joint_vel"], qvel[:, 6:] * 0.05, atol=1e-6, rtol=0)
    torch.testing.assert_close(o["last_action"], action.double())
    torch.testing.assert_close(env.sim.ctrl[1, 0].double(), torch.tensor(5.0 + robot.DEFAULT_JOINT_POS[0]).double())
    feet = torch.linalg.vector_norm(env.body_contact_force[:, env.foot_bodies], dim=-1) > 2.0
    assert torch.all(o["foot_contact"] == torch.where(feet | env.last_contacts, 0.5, -0.5).double())
    assert (o["foot_contact"] == 0.5).sum(-1).min() >= 2  # landed
    # scandots: the original's lookup, in numpy, from the terrain grid, turned as quat_apply_yaw does
    for w in range(2):
        heading = 2.0 * np.arctan2(qpos[w, 6].item(), qpos[w, 3].item())
        expected = _scan_reference(env, heading, pos[w, :2].numpy(), qpos[w, 2].item())
        np.testing.assert_allclose(o["scandots"][w].numpy(), expected, atol=1e-5)
    # the box step (0.2 m, from x = 3 m) is in front of world 1's scan (up to x = 1 + 1.2 m): not yet; a bigger
    # scan of the same lookup would see it, the flat world sees flat ground
    assert np.allclose(o["scandots"][0].numpy(), o["scandots"][0, 0].item(), atol=1e-6)
    com = env.sim.model_field("body_ipos")[:, env.scene.mjm.body(robot.BASE_BODY).id].double().numpy()
    v_com = qvel[:, 0:3].numpy() + np.cross(rot.apply(qvel[:, 3:6].numpy()), rot.apply(com))  # trunk's CoM
    lin = torch.tensor(rot.inv().apply(v_com))
    torch.testing.assert_close(o["base_lin_vel"], lin * 2.0, atol=1e-5, rtol=0)
    d = env.domain
    torch.testing.assert_close(o["added_mass"][:, 0], d.added_mass.double())
    torch.testing.assert_close(o["com_offset"], d.com_offset.double())
    torch.testing.assert_close(o["friction"][:, 0], d.friction.double())
    torch.testing.assert_close(o["motor_strength_p"], d.motor_strength[0].double() - 1)
    torch.testing.assert_close(o["motor_strength_d"], d.motor_strength[1].double() - 1)
    assert o["task_one_hot"].argmax(-1).tolist() == [FLAT, BOX] and o["task_one_hot"].sum() == 2
    assert td["task_id"].tolist() == [FLAT, BOX]


def test_termination_and_time_out() -> None:
    """Roll > 2.5, pitch > 1.5, base below -0.25 m (here: over the synthetic pit) end an episode as terminated;
    the episode length as truncated. Terminated worlds restart at their spawn point."""
    env = _env(columns=("flat", "box_jump_even"), num_rows=1, n=4, episode_length=3, domain_randomization=False)
    td = env.reset()
    roll = torch.tensor(Rotation.from_euler("x", 2.6).as_quat()[[3, 0, 1, 2]], dtype=torch.float32)
    pitch = torch.tensor(Rotation.from_euler("y", 1.52).as_quat()[[3, 0, 1, 2]], dtype=torch.float32)
    upright = torch.tensor([1.0, 0.0, 0.0, 0.0])
    # worlds 0, 1 on the flat tile (y = 2), worlds 2, 3 on the box/pit tile (y = 6; pit from x = 5 to 7 m)
    _teleport(env, torch.tensor([[1.0, 2.0, 0.6], [1.0, 2.0, 0.6], [6.0, 6.0, -0.3], [1.0, 6.0, 0.42]]),
              torch.stack([roll, pitch, upright, upright]))
    nxt, td = _step(env, td)
    assert nxt["terminated"][:, 0].tolist() == [True, True, True, False]
    assert not nxt["truncated"].any()
    assert torch.allclose(env.base_pos[:3, 2], torch.tensor([0.42, 0.42, 0.42]), atol=1e-4)
    assert torch.allclose(env.base_pos[:3, 0], torch.tensor([1.0, 1.0, 1.0]), atol=1e-4)
    nxt, td = _step(env, td)
    assert not nxt["done"].any()
    nxt, td = _step(env, td)  # world 3's third step: time-out
    assert nxt["truncated"][:, 0].tolist() == [False, False, False, True]
    assert not nxt["terminated"].any()
    stats = env.pop_episode_stats()
    assert stats["episodes"][FLAT] == 2 and stats["episodes"][BOX] == 2
    assert stats["length"][BOX] == 1 + 3
    # how they ended, one reason each: roll and pitch on the flat tile, below -0.25 m and the length on the box tile
    assert _ends(stats, FLAT) == {"roll": 1, "pitch": 1}
    assert _ends(stats, BOX) == {"height": 1, "time": 1}


def test_reward_terms_on_constructed_states() -> None:
    n = 4
    state = SimpleNamespace(
        target_pos_rel=torch.tensor([[3.0, 4.0]] * n),  # unit direction (0.6, 0.8)
        base_lin_vel_world=torch.tensor([[1.0, 0.0, 0.3], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]),
        command=torch.tensor([0.5, 0.8, 0.5, 0.0]),
        target_yaw=torch.tensor([1.0, 3.0, 0.0, 0.0]),
        yaw=torch.tensor([0.2, -3.0, 0.0, 0.5]),
        joint_torque=torch.tensor([[2.0, -3.0, 1.0] + [0.0] * 9] * n),
        joint_vel=torch.tensor([[1.0, 1.0, -2.0] + [0.0] * 9] * n),
        body_contact_force=torch.zeros(n, 6, 3),
        penalized_bodies=torch.tensor([1, 2, 3]),
    )
    state.body_contact_force[:, 1, 2] = 0.05  # below 0.1 N
    state.body_contact_force[1:, 2, 0] = 0.2  # a collision in worlds 1..3
    state.body_contact_force[3, 3] = torch.tensor([0.0, 0.3, 0.0])  # and a second one in world 3
    state.body_contact_force[:, 5, 2] = 100.0  # a foot: not penalized
    eps = 1e-5
    expected_vel = torch.tensor([0.5 / (0.5 + eps), 0.6 / (0.8 + eps), -0.6 / (0.5 + eps), np.exp(-0.36 / 0.2)])
    torch.testing.assert_close(tracking_goal_vel(state), expected_vel.float())
    torch.testing.assert_close(tracking_yaw(state), torch.exp(-torch.tensor([0.8, 6.0, 0.0, 0.5])))
    torch.testing.assert_close(energy_cost(state), torch.full((n,), 2.0))
    torch.testing.assert_close(collision(state), torch.tensor([0.0, 1.0, 1.0, 2.0]))
    total, terms = compute_reward(state, REWARD_SCALES, 0.02, only_positive=False)
    expected = 0.02 * (4.0 * expected_vel + torch.exp(-torch.tensor([0.8, 6.0, 0.0, 0.5]))
                       - 0.0005 * 2.0 - 10.0 * torch.tensor([0.0, 1.0, 1.0, 2.0]))
    torch.testing.assert_close(total, expected.float())
    clipped, _ = compute_reward(state, REWARD_SCALES, 0.02, only_positive=True)
    torch.testing.assert_close(clipped, expected.clamp(min=0).float())
    assert (expected < 0).any() and set(terms) == set(REWARD_SCALES)


def test_orientation_term_is_off_by_default_and_measures_the_tilt() -> None:
    """legged_gym's orientation term (not an MTBench Go1 term): g_x^2 + g_y^2 of gravity in the trunk frame."""
    from mtbench.envs.parkour.rewards import orientation

    roll, pitch = 0.4, 0.3
    quats = torch.tensor([
        [1.0, 0.0, 0.0, 0.0],  # level
        [math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0],  # rolled
        [math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0],  # pitched
        [math.cos(0.7), 0.0, 0.0, math.sin(0.7)],  # yawed only: level
    ])
    state = SimpleNamespace(base_quat=quats)
    torch.testing.assert_close(orientation(state),
                               torch.tensor([0.0, math.sin(roll) ** 2, math.sin(pitch) ** 2, 0.0]), atol=1e-6, rtol=0)
    assert "orientation" not in REWARD_SCALES
    total, terms = compute_reward(state, {"orientation": -1.0}, 0.02, only_positive=False)
    torch.testing.assert_close(total, -0.02 * orientation(state))
    assert set(terms) == {"orientation"}


def test_env_reward_is_the_clipped_sum_of_its_terms_and_legs_collide() -> None:
    """A Go1 lying on its side touches the ground with its right thighs and calves: the collision term counts them
    (the default ``terrain_collision="all"`` also lets the trunk and hips touch; only thighs and calves count);
    standing robots only touch with their feet."""
    env = _env(n=2, num_rows=1, domain_randomization=False)
    td = env.reset()
    for _ in range(15):
        nxt, td = _step(env, td)
    assert float(env.reward_terms["collision"][0]) == 0.0
    total = sum(env.reward_terms.values()).clamp(min=0)
    torch.testing.assert_close(nxt["reward"][:, 0], total)
    # lay world 1 on its right side (roll pi/2, right legs pointing sideways along the ground)
    env.sim.qpos[1, 2] = 0.14
    env.sim.qpos[1, 3:7] = torch.tensor([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])
    env.sim.qpos[1, 7:] = env.q_default
    env.sim.qvel[1] = 0.0
    env.sim.kinematics()
    nxt, td = _step(env, td)
    assert not nxt["done"][1]
    assert float(env.reward_terms["collision"][1]) <= -10.0 * 0.02 * 2  # at least 2 leg links
    assert float(env.reward_terms["collision"][0]) == 0.0
    energy = torch.clamp(env.joint_torque * env.joint_vel, min=0).sum(-1) * -0.0005 * 0.02
    torch.testing.assert_close(env.reward_terms["energy_cost"], energy)


def test_domain_randomization_in_model_fields_and_privileged_obs() -> None:
    env = _env(columns=("flat",), num_rows=1, n=6, seed=5)
    td = env.reset()
    d, m = env.domain, env.scene.mjm
    assert torch.all((d.friction >= 0.6) & (d.friction <= 2.0))
    assert torch.all((d.added_mass >= 0) & (d.added_mass <= 3.0))
    assert torch.all(d.com_offset.abs() <= 0.2) and torch.all((d.motor_strength >= 0.8) & (d.motor_strength <= 1.2))
    assert len(set(d.motor_strength.flatten().tolist())) == d.motor_strength.numel()
    trunk = m.body(robot.BASE_BODY).id
    mass = env.sim.model_field("body_mass")[:, trunk]
    torch.testing.assert_close(mass, m.body_mass[trunk] + d.added_mass)
    torch.testing.assert_close(env.sim.model_field("body_ipos")[:, trunk],
                               torch.tensor(m.body_ipos[trunk], dtype=torch.float32) + d.com_offset)
    torch.testing.assert_close(env.sim.model_field("body_subtreemass")[:, 1], m.body_subtreemass[1] + d.added_mass)
    robot_geoms = torch.tensor(np.nonzero(m.geom_bodyid != 0)[0])
    friction = env.sim.model_field("geom_friction")[:, robot_geoms, 0]
    torch.testing.assert_close(friction, ((d.friction + 1.0) / 2)[:, None].expand_as(friction))
    torch.testing.assert_close(env.sim.model_field("actuator_gainprm")[:, :, 0], d.motor_strength[0] * 50.0)
    torch.testing.assert_close(env.sim.model_field("actuator_biasprm")[:, :, 2], -d.motor_strength[1] * 3.0)
    obs = td["observation"]
    torch.testing.assert_close(obs[:, SLICES["added_mass"]][:, 0], d.added_mass)
    torch.testing.assert_close(obs[:, SLICES["friction"]][:, 0], d.friction)
    nominal = _env(columns=("flat",), num_rows=1, n=2, domain_randomization=False)
    latent = nominal.reset()["observation"][:, GROUPS["priv_latent"]]
    assert torch.all(latent[:, 4] == 1.0) and torch.all(latent[:, :4] == 0) and torch.all(latent[:, 5:] == 0)
    assert torch.all(nominal.sim.model_field("actuator_gainprm")[:, :, 0] == 50.0)


def test_curriculum_known_answers_and_demotion_rate() -> None:
    levels = torch.tensor([0, 3, 5, 9, 4, 0, 6, 6])
    goals = torch.tensor([8, 7, 6, 8, 0, 2, 5, 5])
    u_stuck = torch.tensor([0.9, 0.9, 0.9, 0.9, 0.9, 0.1, 0.1, 0.5])
    u_level = torch.tensor([0.5, 0.5, 0.5, 0.55, 0.5, 0.5, 0.5, 0.5])
    new = cl.update_levels(levels, goals, 8, 10, u_stuck, u_level)
    # up (8, 7 goals), stay (6), past the last row -> floor(0.55 * 10), down (0 goals), down stays at 0,
    # stuck + randomized -> floor(0.5 * 6), stuck and kept
    assert new.tolist() == [1, 4, 5, 5, 3, 0, 3, 6]
    g = torch.Generator().manual_seed(0)
    n = 200_000
    stuck_levels = torch.full((n,), 6)
    new = cl.update_levels(stuck_levels, torch.full((n,), 4), 8, 10, torch.rand(n, generator=g),
                           torch.rand(n, generator=g))
    # 4 of 8 goals: no move; a quarter of them go to floor(U * 6), which is always below 6, uniform over 0..5
    moved = new != 6
    assert moved.float().mean().item() == pytest.approx(0.25, abs=0.005)
    counts = torch.bincount(new[moved], minlength=6).float() / moved.sum()
    assert torch.allclose(counts, torch.full((6,), 1 / 6), atol=0.01)
    init = cl.initial_levels(10_000, 10, g, "cpu")
    assert set(init.tolist()) == {0, 1, 2}
    assert set(cl.initial_levels(100, 2, g, "cpu").tolist()) == {0, 1}


def test_levels_are_spread_over_rows_within_each_column_block() -> None:
    env = _env(columns=("flat", "box_jump_even"), num_rows=3, n=7)
    assert env.column.tolist() == [0, 0, 0, 0, 1, 1, 1]
    assert env.level.tolist() == [0, 1, 2, 0, 0, 1, 2]
    assert env.task_id.tolist() == [FLAT] * 4 + [BOX] * 3
    assert env.task_counts[FLAT] == 4 and env.task_counts[BOX] == 3 and sum(env.task_counts) == 7
    obs = env.reset()["observation"]
    origins = torch.as_tensor(env.terrain.tile_origins)[env.level, env.column]
    torch.testing.assert_close(env.base_pos[:, :2], origins[:, :2], atol=1e-4, rtol=0)
    # the first observation: at rest, upright, heading for the first goal straight ahead
    assert torch.all(obs[:, SLICES["base_lin_vel"]] == 0) and torch.all(obs[:, SLICES["roll_pitch"]] == 0)
    assert torch.all(obs[:, SLICES["delta_yaw"]].abs() < 1e-6) and torch.all(obs[:, SLICES["last_action"]] == 0)
    check_env_specs(env)


def test_failed_physics_worlds_are_reset_and_counted() -> None:
    env = _env(columns=("flat", "box_jump_even"), num_rows=1, n=3)
    td = env.reset()
    for _ in range(2):
        nxt, td = _step(env, td)
    env.sim.qvel[1, 8] = float("nan")
    nxt, td = _step(env, td)
    assert nxt["done"][:, 0].tolist() == [False, True, False]
    assert bool(nxt["truncated"][1]) and not bool(nxt["terminated"][1])
    assert float(nxt["reward"][1]) == 0.0
    assert torch.isfinite(td["observation"]).all() and torch.isfinite(env.sim.qpos).all()
    stats = env.pop_episode_stats()
    assert stats["unhealthy"].sum() == 1 and stats["unhealthy"][FLAT] == 1
    assert _ends(stats, FLAT) == {"physics": 1}
    # too few constraint rows for the landing contacts: every world overflows once its feet touch down
    small = _env(columns=("flat",), num_rows=1, n=2, njmax=16)
    td = small.reset()
    dones = 0
    for _ in range(15):
        nxt, td = _step(small, td)
        dones += int(nxt["done"].sum())
    assert small.pop_episode_stats()["unhealthy"].sum() == dones >= 2
    assert torch.isfinite(td["observation"]).all()


def test_base_velocity_is_the_trunk_centre_of_mass_velocity() -> None:
    """As PhysX reports a root body's velocity (the original's ``root_states[:, 7:10]``, used by the goal-velocity
    reward and the privileged observation), the base velocity is the trunk's centre of mass's: the free joint's
    velocity of the frame origin + (R omega_body) x (R com), with each world's randomized centre of mass."""
    env = _env(columns=("flat",), num_rows=1, n=3, seed=5)
    env.reset()
    trunk = env.scene.mjm.body(robot.BASE_BODY).id
    com = env.sim.model_field("body_ipos")[:, trunk].double().numpy()
    assert np.abs(com - env.scene.mjm.body_ipos[trunk]).max() > 0.05  # randomized offsets (+-0.2 m)
    rot = Rotation.from_euler("ZYX", [[0.3, 0.2, -0.1], [-1.0, 0.0, 0.4], [2.0, -0.3, 0.0]])
    quat = rot.as_quat()[:, [3, 0, 1, 2]]
    v0, omega_b = np.array([[0.5, 0.1, 0.0], [0.0, -0.2, 0.3], [0.0, 0.0, 0.0]]), np.array(
        [[0.0, 0.0, 2.0], [1.0, -3.0, 0.5], [4.0, 0.0, 0.0]])
    env.sim.qpos[:, 3:7] = torch.tensor(quat, dtype=torch.float32)
    env.sim.qvel[:, 0:3] = torch.tensor(v0, dtype=torch.float32)
    env.sim.qvel[:, 3:6] = torch.tensor(omega_b, dtype=torch.float32)
    env._read_state()
    expected = v0 + np.cross(rot.apply(omega_b), rot.apply(com))
    np.testing.assert_allclose(env.base_lin_vel_world.double().numpy(), expected, atol=1e-5)
    np.testing.assert_allclose(env.base_lin_vel.double().numpy(), rot.inv().apply(expected), atol=1e-5)
    assert np.abs(expected - v0).max() > 0.1  # not the frame origin's


def _scan_reference(env: ParkourEnv, heading: float, xy: np.ndarray, base_z: float) -> np.ndarray:
    """The original's scandots in numpy: the 12 x 11 points turned by ``heading``, min of 3 grid samples."""
    t = env.terrain
    gx, gy = np.meshgrid(np.array(SCAN_X), np.array(SCAN_Y), indexing="ij")
    c, s = np.cos(heading), np.sin(heading)
    px = c * gx.ravel() - s * gy.ravel() + xy[0]
    py = s * gx.ravel() + c * gy.ravel() + xy[1]
    a = np.clip(np.floor((px + t.border) / 0.05).astype(int), 0, t.heights.shape[0] - 2)
    b = np.clip(np.floor((py + t.border) / 0.05).astype(int), 0, t.heights.shape[1] - 2)
    h = np.minimum(np.minimum(t.heights[a, b], t.heights[a + 1, b]), t.heights[a, b + 1])
    return np.clip(base_z - 0.3 - h, -1, 1)


def test_scan_points_turn_with_the_originals_quat_apply_yaw() -> None:
    """The original turns the scan points by ``quat_apply_yaw`` (the base quaternion with its x, y parts zeroed: a
    turn about z by 2 atan2(q_z, q_w)), not by the Euler yaw; the two differ for a tilted trunk, and on a terrain
    with edges the scandots differ with them."""
    env = _env(columns=("box_jump_even",), num_rows=1, n=1)
    env.reset()
    rot = Rotation.from_euler("ZYX", [0.6, 0.5, 0.6])  # yaw, pitch, roll: a strongly tilted trunk
    xyzw = rot.as_quat()
    heading = 2.0 * math.atan2(xyzw[2], xyzw[3])
    assert abs(heading - 0.6) > 0.1  # not the Euler yaw
    xy = np.array([2.9, 2.0])  # near the end of the first platform
    _teleport(env, torch.tensor([[xy[0], xy[1], 0.35]]), torch.tensor(xyzw[[3, 0, 1, 2]], dtype=torch.float32))
    env._read_state()
    base_z = float(env.base_pos[0, 2])
    scan = scandots(env.base_pos[:, 2], env._scan())[0].numpy()
    np.testing.assert_allclose(scan, _scan_reference(env, heading, xy, base_z), atol=1e-5)
    assert np.abs(scan - _scan_reference(env, 0.6, xy, base_z)).max() > 0.1


def test_trunk_on_too_many_heightfield_prisms_is_counted_not_reset() -> None:
    """A robot on its side pressed into the rough ground touches more than 50 heightfield prisms with its trunk
    box (MuJoCo Warp's per-pair limit, an ``HFIELD`` overflow). MuJoCo Warp keeps the contacts of the first 50, so
    the episode goes on as the original's would (a failed-physics reset, bootstrapped as a time-out, would hide the
    crash from the learner): the step is counted in ``contact_overflow``, the world is not reset, and the robot
    rests on the ground instead of sinking through it."""
    env = _env(columns=("flat",), num_rows=1, n=4)
    assert env.sim.fatal_overflow & HFIELD_OVERFLOW == 0 and env.sim.fatal_overflow & FATAL_OVERFLOW
    td = env.reset()
    pos = env.base_pos.clone()
    pos[:, 2] = 0.03
    roll = 1.4  # on its side (the fall rule needs |roll| > 2.5)
    _teleport(env, pos, torch.tensor([math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0]))
    nxt, td = _step(env, td)
    assert not nxt["done"].any() and torch.isfinite(nxt["reward"]).all()
    stats = env.pop_episode_stats()
    assert stats["contact_overflow"][FLAT] == 4 and stats["unhealthy"].sum() == 0
    for _ in range(20):
        nxt, td = _step(env, td)
        assert not nxt["truncated"].any()
    assert torch.isfinite(env.sim.qpos).all() and bool((env.base_pos[:, 2] > 0.02).all())


def test_first_episodes_start_at_random_progress_and_are_not_counted() -> None:
    env = _env(columns=("flat",), num_rows=1, n=8, episode_length=6, random_start_progress=True, seed=2)
    td = env.reset()
    start = env.progress.clone()
    assert len(set(start.tolist())) > 1 and start.max() < 6
    for _ in range(6):
        nxt, td = _step(env, td)
    stats = env.pop_episode_stats()
    assert stats["episodes"][FLAT] == int((start == 0).sum())
    assert stats["length"][FLAT] == 6 * int((start == 0).sum())


def test_excluded_episodes_are_left_out_of_the_statistics() -> None:
    env = _env(columns=("flat",), num_rows=1, n=4, episode_length=3)
    td = env.reset()
    for _ in range(3):
        _, td = _step(env, td)
    assert env.pop_episode_stats()["episodes"][FLAT] == 4
    env.exclude_episodes(torch.tensor([True, False, True, False]))  # their second episodes
    for _ in range(3):
        _, td = _step(env, td)
    stats = env.pop_episode_stats()
    assert stats["episodes"][FLAT] == 2 and stats["length"][FLAT] == 6
    for _ in range(3):  # the third episodes count again
        _, td = _step(env, td)
    assert env.pop_episode_stats()["episodes"][FLAT] == 4


def test_checkpoint_round_trip_continues_the_same_trajectories() -> None:
    kw = dict(columns=("flat", "box_jump_even"), num_rows=2, n=4, curriculum=True, push_robots=True,
              random_start_progress=True, episode_length=9)
    a = _env(seed=4, **kw)
    g = torch.Generator().manual_seed(9)
    actions = torch.randn(30, 4, 12, generator=g)
    td = a.reset()
    for act in actions[:13]:
        _, td = _step(a, td, act)
    state = a.state_dict()
    b = _env(seed=123, **kw)  # different seed: the domain randomization and RNG come from the state
    b.load_state_dict(state)
    td_b = td.clone()
    for act in actions[13:]:
        out_a, td = _step(a, td, act)
        out_b, td_b = _step(b, td_b, act)
        torch.testing.assert_close(td["observation"], td_b["observation"], atol=1e-5, rtol=0)
        torch.testing.assert_close(out_a["reward"], out_b["reward"], atol=1e-6, rtol=0)
        assert torch.equal(out_a["done"], out_b["done"])
    assert torch.equal(a.level, b.level) and torch.equal(a.progress, b.progress)
    assert torch.equal(a.pop_episode_stats()["episodes"], b.pop_episode_stats()["episodes"])
    other = _env(columns=("flat",), num_rows=2, n=4)
    with pytest.raises(RuntimeError, match="env state is for columns"):
        other.load_state_dict(state)
    # a state saved before the end_<reason> rows (8 statistics rows): those rows load, the new ones start at zero
    saved = state["_extra_state"]["env"]["_stats"]
    assert saved.shape[0] == 8 + len(END_REASONS) and saved[0].sum() > 0  # episodes finished since the last pop
    old = {"_extra_state": {**state["_extra_state"], "env": {**state["_extra_state"]["env"], "_stats": saved[:8]}}}
    c = _env(seed=5, **kw)
    c._stats.fill_(7.0)
    c.load_state_dict(old)
    assert torch.equal(c._stats[:8], saved[:8]) and not c._stats[8:].any()


def test_make_env_settings_on_the_generated_terrain() -> None:
    env = make_env("parkour_hard", num_envs=42, device="cpu", num_rows=2, seed=0)
    assert env.num_tasks == 21 and env.task_names == list(TERRAIN_NAMES) and env.max_episode_steps == 2000
    assert env.task_counts == [2] * 21 and env.task_id.tolist() == [t for t in range(21) for _ in range(2)]
    assert env.level.tolist() == [0, 1] * 21 and not env.curriculum
    assert env.success_metric == "progress"
    check_env_specs(env)
    flat = make_env("parkour_flat", num_envs=21, device="cpu", num_rows=1)
    assert flat.task_id.tolist() == [FLAT] * 21 and flat.task_counts[FLAT] == 21
    assert flat.reset()["observation"][:, SLICES["task_one_hot"]].argmax(-1).tolist() == [FLAT] * 21
    assert flat.terrain.config.easy and flat.terrain.config.columns == ("flat",) * 21
    with pytest.raises(ValueError, match="valid choices"):
        make_env(["flat", "not_a_terrain"], num_envs=2, device="cpu")
    with pytest.raises(ValueError, match="total num_envs"):
        make_env("parkour_easy", num_envs=[1] * 21, device="cpu")


def test_the_robot_can_jump_higher_than_the_jump_terrains_ask() -> None:
    """The actuator model (PD gains, torque limit, masses, joint limits) leaves the Go1 strong enough for the jump
    terrains: from standing on flat ground, 12 policy steps of a crouch (thighs +0.6, calves -0.8 rad from the
    default pose) and 6 of full extension (thighs -0.6, calves +1.2, past the calf limit) throw the trunk at least
    0.3 m above its standing height in every world that stands upright after the reset's random joint offsets and
    does not fall before the take-off (measured 2026-11-28: 0.35-0.51 m, domain-randomized masses and motor
    strengths); box_jump_even's gaps at difficulty 0 are 0.4-0.5 m wide. The robot comes back down."""
    with one_torch_thread():
        env = make_env("parkour_flat", num_envs=21, device="cpu", seed=0, num_rows=1)
        td = env.reset()
        thigh = torch.tensor([0.0, 1.0, 0.0] * 4)
        calf = torch.tensor([0.0, 0.0, 1.0] * 4)
        plan = [torch.zeros(12)] * 30 + [0.6 * thigh - 0.8 * calf] * 12 + [-0.6 * thigh + 1.2 * calf] * 6
        plan += [torch.zeros(12)] * 50
        heights, done = [], torch.zeros(21, dtype=torch.bool)
        for i, a in enumerate(plan):
            td["action"] = a.expand(21, 12).clone()
            out, td = env.step_and_maybe_reset(td)
            heights.append(env.base_pos[:, 2].clone())
            if i < 48:  # until the take-off
                done |= out["next", "done"].reshape(21)
            if i == 29:
                upright = (env.roll.abs() < 0.15) & (env.pitch.abs() < 0.15)
        z = torch.stack(heights)  # [steps, worlds]
        ok = upright & ~done
        assert int(ok.sum()) >= 10
        standing, crouched, flight = z[29, ok], z[41, ok], z[42:, ok]
        assert bool((crouched < standing - 0.1).all())
        assert bool((flight.max(0).values > standing + 0.3).all()), (flight.max(0).values - standing).tolist()
        assert bool((z[-20:, ok].min(0).values < flight.max(0).values - 0.2).all())  # and comes back down


def test_contact_time_constant_reaches_the_simulated_model() -> None:
    """``robot_contact_timeconst`` (an env override) is the solref of the robot's collision geoms in the model that
    MuJoCo Warp simulates: 0.01 s by default, MuJoCo's own 0.02 s with None."""
    for kwargs, expected in (({"robot_contact_timeconst": None}, 0.02), ({}, 0.01)):
        env = _env(**kwargs)
        solref = env.sim.model_field("geom_solref")[0]  # [ngeom, 2] of world 0
        robot_geoms = torch.as_tensor(env.scene.mjm.geom_contype != 0)
        assert env.scene.robot_contact_timeconst == (None if kwargs else 0.01)
        assert torch.allclose(solref[robot_geoms], torch.tensor([expected, 1.0]).expand(int(robot_geoms.sum()), 2))


def test_collision_pieces_reach_the_simulated_model() -> None:
    """``robot_collision_pieces`` (an env override) cuts the robot's boxes and long capsules in the model that MuJoCo
    Warp simulates (48 robot/terrain pairs at 4 pieces instead of 18, contact buffers sized for them); standing robots
    stand alike (feet are never cut); a bad value gets one error naming the parameter."""
    heights = {}
    for pieces in (1, 4):
        env = _env(n=2, robot_collision_pieces=pieces)
        assert env.scene.robot_collision_pieces == pieces
        assert env.scene.contact_pairs == (18 if pieces == 1 else 48)
        names = [env.scene.mjm.geom(g).name for g in range(env.scene.mjm.ngeom) if env.scene.mjm.geom_contype[g]]
        assert ("trunk_box" in names) == (pieces == 1) and ("trunk_box_3" in names) == (pieces == 4)
        td = env.reset()
        for _ in range(10):
            td = env.step(td.set("action", torch.zeros(2, 12)))["next"]
        assert env.pop_episode_stats()["unhealthy"].sum() == 0
        heights[pieces] = env.sim.qpos[:, 2].clone()
    assert torch.allclose(heights[4], heights[1], atol=1e-4), heights
    with pytest.raises(ValueError, match=r"robot_collision_pieces must be an integer in \[1, 8\]"):
        _env(robot_collision_pieces=0)
