"""The batched Parkour env (TorchRL ``EnvBase``): a Unitree Go1 per world on the MTBench terrain grid (MuJoCo Warp).

One MuJoCo model (Go1 + terrain heightfield, ``scene.py``) simulated for all worlds by one ``WarpSim``; each world's
robot runs on its own tile. Worlds form contiguous blocks per terrain column (``split_envs``); within a block they are
spread evenly over the difficulty rows (world ``k`` of a block on row ``k % num_rows``), or start on random rows
``0..2`` and follow the curriculum (``curriculum=True``, Parkour-hard-cl).

A step (MTBench ``legged_base.py``, ``final_go1_*.yaml``): the action (12, clipped to +-5) sets PD joint targets
(``robot.py``), 4 physics steps of 5 ms run in one graph, then waypoints, commands, scandots, termination, rewards,
statistics, the curriculum and the autoreset of finished worlds are computed on the device with no host
synchronisation (on the GPU as CUDA graphs replayed between the physics graphs, as ``MetaWorldEnv`` does).

Deliberate differences from the original (see ``docs/parkour.md``): the first observation of an episode is computed
from the new state (the original keeps some pre-reset values and refreshes yaw/scandots only every 5th global step);
no extra physics step is taken when worlds reset; episodes time out after exactly ``episode_length`` steps; worlds
whose physics failed (non-finite state, a dropped contact or constraint) are reset and counted as ``unhealthy``. A
robot geom touching more than 50 heightfield prisms (the trunk lying on the ground) is not such a failure: MuJoCo
Warp keeps the contacts of the first 50 and the episode goes on, as the original's would; those steps are counted
(``contact_overflow``).
"""

from __future__ import annotations

from typing import Mapping

import mujoco
import numpy as np
import torch
import warp as wp
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

from ...sim import FATAL_OVERFLOW, HFIELD_OVERFLOW, WarpSim, launch_all, warp_device
from ...utils import GraphedStage
from ..inputs import checked_action, reset_mask
from . import curriculum as cl
from . import domain_rand, robot
from .height_scan import HeightGrid, scan_points
from .observation import NUM_TASK_SLOTS, OBS_DIM, STATE_DIM, assemble, scandots
from ..rotations import euler_from_quat, quat_rotate, quat_rotate_inverse
from .rewards import REWARD_SCALES, check_scales, compute_reward
from .scene import build_scene
from .terrains import NUM_GOALS, TERRAIN_NAMES

ACTION_DIM = robot.NUM_JOINTS
POLICY_DT = robot.SIM_DT * robot.DECIMATION  # 0.02 s
COMMAND_RANGE = (0.3, 0.8)  # forward speed command, m/s
COMMAND_MIN = 0.2  # commands below this are zeroed (never with COMMAND_RANGE)
COMMAND_RESAMPLE_STEPS = 300  # 6 s
REFRESH_STEPS = 5  # yaw deltas and scandots refresh period (global steps)
PUSH_STEPS = 400  # 8 s
PUSH_VELOCITY = 0.5  # m/s, base vx, vy ~ U(-0.5, 0.5)
GOAL_RADIUS = 0.3  # m
GOAL_STEPS = 1  # a goal is reached after more than this many steps within GOAL_RADIUS
FOOT_CONTACT_FORCE = 2.0  # N
RESET_JOINT_NOISE = (0.0, 0.9)  # rad added to every default joint angle at reset
MAX_ROLL, MAX_PITCH, MIN_BASE_Z = 2.5, 1.5, -0.25
# how a counted episode ended, one reason per episode (``end_<reason>`` rows of pop_episode_stats, in this order of
# precedence): all goals reached, the episode length, a fall below MIN_BASE_Z, a roll past MAX_ROLL, a pitch past
# MAX_PITCH, a failed physics state
END_REASONS = ("goals", "time", "height", "roll", "pitch", "physics")
STAT_ROWS = ("episodes", "success", "return", "length", "unhealthy", "terrain_level", "nonfinite_actions",
             "contact_overflow", *(f"end_{reason}" for reason in END_REASONS))


class ParkourEnv(EnvBase):
    """Go1 Parkour: ``num_envs`` worlds on the tiles of ``terrain``.

    Observation ``[N, 233]`` (``observation.py``: proprio 48, scandots 132, base velocity 3, privileged latent 29,
    task one-hot 21; the one-hot always has the 21 canonical slots), ``task_id`` ``[N]`` (canonical id 0..20),
    action ``[N, 12]`` (joint target offsets in rad, clipped to +-5), reward ``[N, 1]``, ``terminated`` (fall: |roll| >
    2.5, |pitch| > 1.5 or base z < -0.25 m), ``truncated`` (time-out, all 8 goals reached, or a failed physics
    state). The env resets finished worlds itself (TorchRL native autoreset) and returns the first observation of the
    next episode. ``pop_episode_stats()`` reports per task ``success`` as the summed progress (goals reached / 8) of
    finished episodes (``success_metric = "progress"``).

    Args:
        terrain: a generated ``terrain.Terrain`` (its columns decide the worlds' tasks).
        num_envs: number of worlds (split over the columns in contiguous blocks, the first blocks get the remainder).
        device: torch device; the physics runs on the matching Warp device.
        seed: seed of the env's random generator (domain randomization, resets, commands, pushes, curriculum).
        curriculum: Parkour-hard-cl's terrain curriculum (``curriculum.py``); False: fixed rows.
        max_init_level: highest initial row with the curriculum (2).
        episode_length: policy steps per episode (2000 = 40 s).
        terrain_collision: robot geoms that touch the terrain, ``"all"`` (default, as the original: + hips and
            trunk), ``"legs"`` (feet, calves, thighs) or ``"feet"`` (``robot.TERRAIN_COLLISIONS``); the collision
            penalty needs ``"legs"`` or ``"all"``. Without the trunk, policies learn to crawl with the trunk inside
            the ground (docs/parkour.md).
        robot_inertia: the Go1's masses, centres of mass, inertias and joint armature: ``"menagerie"`` (default,
            12.74 kg) or ``"urdf"`` (the original's ``go1_with_camera.urdf``, 11.31 kg; ``robot.INERTIAL_MODELS``,
            docs/parkour.md).
        robot_armature: the joints' rotor armature in kg m^2 (None: the inertial model's, 0.01 / 0.007; the original
            has 0, which needs ``robot_integrator="implicitfast"``).
        robot_integrator: ``"euler"`` (default: explicit PD damping) or ``"implicitfast"`` (MuJoCo's implicit
            actuator damping, stable without armature; ``robot.INTEGRATORS``).
        robot_contact_timeconst: the time constant in s of the robot's terrain contacts (default 0.01, the stiffest
            MuJoCo allows at this timestep, feet sink ~1 mm; None: MuJoCo's own 0.02, soft, 1-2 cm at impacts, where the
            policies do not learn to jump, docs/parkour.md; the original's PhysX contacts are rigid).
        robot_collision_pieces: each box and long capsule of the robot's collision set as this many equal pieces
            along its longest axis (default 1: whole; up to 8): the same solids, in more and shorter heightfield
            collision threads on the GPU; measured 4-10% slower there (docs/parkour.md, "Collision pieces").
        terrain_representation: ``"tiles"`` (one heightfield per tile, selected per world; physics in tile
            frames) or ``"grid"`` (one heightfield for the whole grid; MuJoCo Warp's heightfield contacts go wrong
            more than ~20 m from its centre: small grids only); see ``scene.py``.
        tile_margin: metres of neighbouring terrain around each tile heightfield (``"tiles"`` only).
        domain_randomization: sample friction, added mass, CoM offset and motor strengths per world
            (``domain_rand.py``); False: the nominal robot.
        push_robots: set every world's base xy velocity to U(-0.5, 0.5) m/s every 400 steps.
        reward_scales: ``{term: scale}`` (default ``rewards.REWARD_SCALES``), each multiplied by dt = 0.02.
        only_positive_rewards: clip the total reward at 0.
        random_start_progress: start each world at a random step of its first episode (MTBench); that shortened
            first episode is not counted in the statistics.
        nconmax, njmax: contact / constraint buffer sizes per world (default: sized for ``terrain_collision``).
        use_graph: capture the physics as graphs (CUDA graphs on the GPU, Warp CPU graphs on the CPU).
        torch_graphs: on the GPU, replay the env's torch work from CUDA graphs after ``graph_warmup`` eager steps.
        graph_warmup: eager steps before the torch work is captured.
    """

    _torchrl_native_autoreset = True
    success_metric = "progress"
    #: evaluation videos (``mtbench.evaluation.CameraSpec`` fields): following the trunk from behind and to its
    #: right, above the tile's 0.5 m side walls, looking at the ground ahead (the robot walks left to right)
    video_camera = {"eye": (-1.0, -2.8, 1.6), "target": (1.0, 0.0, -0.2), "track_body": robot.BASE_BODY}

    def __init__(
        self,
        terrain,
        num_envs: int,
        *,
        device: torch.device | str = "cpu",
        seed: int = 0,
        curriculum: bool = False,
        max_init_level: int = cl.MAX_INIT_LEVEL,
        episode_length: int = 2000,
        terrain_collision: str = robot.DEFAULT_TERRAIN_COLLISION,
        robot_inertia: str = robot.DEFAULT_INERTIAL_MODEL,
        robot_armature: float | None = None,
        robot_integrator: str = robot.DEFAULT_INTEGRATOR,
        robot_contact_timeconst: float | None = robot.DEFAULT_CONTACT_TIMECONST,
        robot_collision_pieces: int = robot.DEFAULT_COLLISION_PIECES,
        terrain_representation: str = "tiles",
        tile_margin: float = 1.0,
        domain_randomization: bool = True,
        push_robots: bool = True,
        reward_scales: Mapping[str, float] | None = None,
        only_positive_rewards: bool = True,
        random_start_progress: bool = True,
        nconmax: int | None = None,
        njmax: int | None = None,
        use_graph: bool = True,
        torch_graphs: bool = True,
        graph_warmup: int = 2,
    ) -> None:
        from ..make import split_envs

        columns = tuple(terrain.config.columns)
        counts = split_envs(int(num_envs), len(columns))
        if episode_length < 1:
            raise ValueError(f"episode_length must be positive, got {episode_length}")
        if max_init_level < 0:
            raise ValueError(f"max_init_level must be >= 0, got {max_init_level}")
        self.reward_scales = check_scales(REWARD_SCALES if reward_scales is None else reward_scales)
        warp_device(device)
        super().__init__(device=device, batch_size=torch.Size([int(num_envs)]))
        self.__dict__["_torchrl_native_autoreset"] = True
        dev = self.device
        n = int(num_envs)
        self.terrain = terrain
        self.num_rows = int(terrain.tile_origins.shape[0])
        self.task_names = list(TERRAIN_NAMES)
        self.num_tasks = NUM_TASK_SLOTS
        self.state_dim = STATE_DIM
        self.max_episode_steps = int(episode_length)
        self.curriculum = bool(curriculum)
        self.only_positive_rewards = bool(only_positive_rewards)
        self.push_robots = bool(push_robots)
        self.random_start_progress = bool(random_start_progress)
        self.columns = columns
        self.column_counts = counts
        self._generator = torch.Generator(device=dev)
        self._generator.manual_seed(seed)

        # worlds: contiguous blocks per column; task id = the column's canonical task id
        column_task = torch.as_tensor(np.asarray(terrain.task_ids), dtype=torch.long, device=dev)
        self.column = torch.repeat_interleave(torch.arange(len(columns), device=dev), torch.tensor(counts, device=dev))
        self.task_id = column_task[self.column]
        self.task_counts = torch.bincount(self.task_id, minlength=self.num_tasks).tolist()
        self._one_hot = torch.nn.functional.one_hot(self.task_id, self.num_tasks).float()
        if self.curriculum:
            levels = cl.initial_levels(n, self.num_rows, self._generator, dev, max_init_level)
        else:
            local = torch.cat([torch.arange(c, device=dev) for c in counts])
            levels = local % self.num_rows
        self.level = levels.clone()

        # physics: one model, one WarpSim, per-world domain randomization
        self.scene = build_scene(terrain, terrain_collision, terrain_representation, tile_margin, robot_inertia,
                                 robot_armature, robot_integrator, robot_contact_timeconst, robot_collision_pieces)
        mjm = self.scene.mjm
        pairs = self.scene.contact_pairs
        nconmax = 4 * pairs if nconmax is None else nconmax  # MuJoCo Warp makes <= 4 contacts per heightfield pair
        njmax = 3 * 4 * pairs + robot.NUM_JOINTS if njmax is None else njmax  # 3 rows per contact + joint limits
        batched = domain_rand.BATCHED_FIELDS + (("geom_dataid",) if terrain_representation == "tiles" else ())
        # a geom on more than 50 heightfield prisms keeps a partial contact set: not a failed physics state
        self.sim = WarpSim(mjm, n, dev, substeps=robot.DECIMATION, nconmax=nconmax, njmax=njmax,
                           batched_fields=batched, use_graph=use_graph, contact_forces=True,
                           fatal_overflow=FATAL_OVERFLOW & ~HFIELD_OVERFLOW)
        self.domain = domain_rand.sample(n, self._generator, dev, enabled=domain_randomization)
        domain_rand.apply(self.sim, mjm, self.domain)
        self._body_ipos = self.sim.model_field("body_ipos")  # [N, nbody, 3], the trunk's per world
        self._trunk_body = mujoco.mj_name2id(mjm, mujoco.mjtObj.mjOBJ_BODY, robot.BASE_BODY)

        # terrain on the device
        self.height_grid = HeightGrid(torch.as_tensor(terrain.heights, device=dev), terrain.config.horizontal_scale,
                                      terrain.border)
        self._scan_points = scan_points(dev)
        self._tile_origin = torch.as_tensor(terrain.tile_origins, dtype=torch.float32, device=dev)
        self._tile_goals = torch.as_tensor(terrain.goals, dtype=torch.float32, device=dev)
        self._tile_offset = torch.as_tensor(self.scene.tile_offset, dtype=torch.float32, device=dev)
        self._tile_hfield = torch.as_tensor(self.scene.tile_hfield, dtype=torch.int32, device=dev)
        self._geom_dataid = (self.sim.model_field("geom_dataid")[:, self.scene.hfield_geom]
                             if terrain_representation == "tiles" else None)

        body = lambda name: mujoco.mj_name2id(mjm, mujoco.mjtObj.mjOBJ_BODY, name)  # noqa: E731
        self.foot_bodies = torch.tensor([body(b) for b in robot.FOOT_BODIES], device=dev)
        self.penalized_bodies = torch.tensor([body(b) for b in robot.THIGH_BODIES + robot.CALF_BODIES], device=dev)
        self.q_default = torch.as_tensor(robot.DEFAULT_JOINT_POS, dtype=torch.float32, device=dev)
        self._arange = torch.arange(n, device=dev)
        self._spawn_lift = torch.tensor([0.0, 0.0, robot.BASE_INIT_HEIGHT], device=dev)
        self._upright = torch.tensor([1.0, 0.0, 0.0, 0.0], device=dev).expand(n, 4)

        # named state, updated in place (the step may be replayed from CUDA graphs)
        z = lambda *shape, dtype=torch.float32: torch.zeros(n, *shape, dtype=dtype, device=dev)  # noqa: E731
        self.world_offset = z(3)  # world position of each world's physics frame origin (tile frame with "tiles")
        self.goals = z(NUM_GOALS, 3)  # the world's tile waypoints (world frame)
        self.base_pos, self.base_quat = z(3), z(4)
        self.base_lin_vel_world, self.base_lin_vel, self.base_ang_vel = z(3), z(3), z(3)
        self.roll, self.pitch, self.yaw = z(), z(), z()
        self.joint_pos, self.joint_vel = z(robot.NUM_JOINTS), z(robot.NUM_JOINTS)
        self.joint_torque = wp.to_torch(self.sim.data.actuator_force)  # last substep's PD torques
        self.body_contact_force = self.sim.body_contact_force
        self.command = z()
        self.cur_goal_idx = z(dtype=torch.long)
        self.reach_timer = z(dtype=torch.long)
        self.target_pos_rel, self.next_target_pos_rel = z(2), z(2)
        self.target_yaw, self.next_target_yaw = z(), z()
        self.delta_yaw, self.delta_next_yaw = z(), z()
        self.ground = z(self._scan_points.shape[0])  # terrain heights under the scan points (last refresh)
        self.last_action = z(ACTION_DIM)
        self.last_contacts = z(4, dtype=torch.bool)
        self.contact_filt = z(4, dtype=torch.bool)
        self.progress = z(dtype=torch.long)
        self.global_step = torch.zeros((), dtype=torch.long, device=dev)
        self._ep_return = z()
        self._ep_counted = torch.ones(n, dtype=torch.bool, device=dev)
        self._stats = torch.zeros(len(STAT_ROWS), self.num_tasks, device=dev)
        self._nonfinite_action = torch.zeros(n, dtype=torch.bool, device=dev)
        self._max_level = torch.full((self.num_tasks,), -1, dtype=torch.long, device=dev)
        # step buffers: the stages communicate only through these
        self._action_in = z(ACTION_DIM)
        self._reward = z()
        self._terminated = z(dtype=torch.bool)
        self._truncated = z(dtype=torch.bool)
        self._done = z(dtype=torch.bool)
        self._obs = z(OBS_DIM)
        self.reward_terms = {name: z() for name in self.reward_scales}

        enabled = torch_graphs and dev.type == "cuda"
        pool = torch.cuda.graph_pool_handle() if enabled else None
        stream = torch.cuda.Stream(device=dev) if enabled else None
        stage = dict(device=dev, warmup=graph_warmup, pool=pool, stream=stream, enabled=enabled,
                     generators=(self._generator,))
        self._stages = (
            GraphedStage(self._stage_action, name="action", **stage),
            GraphedStage(self._stage_evaluate, name="evaluate", **stage),
            GraphedStage(self._stage_place, name="place", **stage),
            GraphedStage(self._stage_finish, name="finish", **stage),
        )
        self._make_specs()

    # ------------------------------------------------------------------ specs
    def _make_specs(self) -> None:
        n, dev, k = self.batch_size[0], self.device, self.num_tasks
        self.observation_spec = Composite(
            observation=Unbounded(shape=(n, OBS_DIM), device=dev),
            task_id=Categorical(k, shape=(n,), dtype=torch.long, device=dev),
            shape=(n,),
            device=dev,
        )
        limit = robot.ACTION_CLIP / robot.ACTION_SCALE
        self.action_spec = Bounded(-limit, limit, shape=(n, ACTION_DIM), device=dev)
        self.reward_spec = Unbounded(shape=(n, 1), device=dev)
        done = Categorical(2, shape=(n, 1), dtype=torch.bool, device=dev)
        self.full_done_spec = Composite(done=done.clone(), terminated=done.clone(), truncated=done.clone(),
                                        shape=(n,), device=dev)

    # ------------------------------------------------------------------ state
    def _uniform(self, shape: tuple[int, ...], lo: float, hi: float) -> torch.Tensor:
        return lo + (hi - lo) * torch.rand(shape, generator=self._generator, device=self.device)

    def _read_state(self) -> None:
        """Base pose and velocities, roll/pitch/yaw and joint state of every world from the simulator."""
        qpos, qvel = self.sim.qpos, self.sim.qvel
        self.base_pos.copy_(qpos[:, 0:3] + self.world_offset)
        self.base_quat.copy_(qpos[:, 3:7])
        self.base_ang_vel.copy_(qvel[:, 3:6])  # free joint: body-frame angular velocity
        # the trunk's centre-of-mass velocity, as PhysX reports a root body's (the original's root_states[:, 7:10]):
        # the free joint's world-frame velocity of the trunk frame origin + omega x (R com), with the per-world
        # (domain-randomized) centre of mass
        com = quat_rotate(self.base_quat, self._body_ipos[:, self._trunk_body])
        omega = quat_rotate(self.base_quat, self.base_ang_vel)
        self.base_lin_vel_world.copy_(qvel[:, 0:3] + torch.cross(omega, com, dim=-1))
        self.base_lin_vel.copy_(quat_rotate_inverse(self.base_quat, self.base_lin_vel_world))
        roll, pitch, yaw = euler_from_quat(self.base_quat)
        self.roll.copy_(roll)
        self.pitch.copy_(pitch)
        self.yaw.copy_(yaw)
        self.joint_pos.copy_(qpos[:, 7:])
        self.joint_vel.copy_(qvel[:, 6:])

    def _goal_targets(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Current and next waypoints ``[N, 3]`` (past the last goal: the last goal, as the original's padding)."""
        idx = self.cur_goal_idx.clamp(max=NUM_GOALS - 1)
        nxt = (self.cur_goal_idx + 1).clamp(max=NUM_GOALS - 1)
        return self.goals[self._arange, idx], self.goals[self._arange, nxt]

    def _set_targets(self, mask: torch.Tensor | None = None) -> None:
        """Target vectors and yaws towards the current and next goals (for the worlds of ``mask``, else all)."""
        cur, nxt = self._goal_targets()
        rel = cur[:, :2] - self.base_pos[:, :2]
        next_rel = nxt[:, :2] - self.base_pos[:, :2]
        yaw = torch.atan2(rel[:, 1], rel[:, 0])
        next_yaw = torch.atan2(next_rel[:, 1], next_rel[:, 0])
        if mask is None:
            self.target_pos_rel.copy_(rel)
            self.next_target_pos_rel.copy_(next_rel)
            self.target_yaw.copy_(yaw)
            self.next_target_yaw.copy_(next_yaw)
        else:
            m = mask[:, None]
            self.target_pos_rel.copy_(torch.where(m, rel, self.target_pos_rel))
            self.next_target_pos_rel.copy_(torch.where(m, next_rel, self.next_target_pos_rel))
            self.target_yaw.copy_(torch.where(mask, yaw, self.target_yaw))
            self.next_target_yaw.copy_(torch.where(mask, next_yaw, self.next_target_yaw))

    def _update_goals(self) -> None:
        """The original's ``_update_goals``: count steps within ``GOAL_RADIUS`` of the current goal, aim at it, and
        move to the next goal once the count exceeds ``GOAL_STEPS`` (the count is not cleared when the base leaves
        the radius, as in the original)."""
        cur, _ = self._goal_targets()
        reached = torch.linalg.vector_norm(self.base_pos[:, :2] - cur[:, :2], dim=-1) < GOAL_RADIUS
        self.reach_timer.add_(reached.long())
        self._set_targets()
        advance = self.reach_timer > GOAL_STEPS
        self.cur_goal_idx.add_(advance.long())
        self.reach_timer.masked_fill_(advance, 0)

    def _scan(self) -> torch.Tensor:
        # the original's quat_apply_yaw: the base quaternion with its x, y parts zeroed, i.e. a turn about z by
        # 2 atan2(q_z, q_w) (the Euler yaw's equal only for an upright trunk)
        heading = 2.0 * torch.atan2(self.base_quat[:, 3], self.base_quat[:, 0])
        return self.height_grid.scan(self.base_pos[:, :2], heading, self._scan_points)

    def _sample_commands(self, mask: torch.Tensor) -> None:
        cmd = self._uniform(self.command.shape, *COMMAND_RANGE)
        cmd = cmd * (cmd >= COMMAND_MIN)
        self.command.copy_(torch.where(mask, cmd, self.command))

    def _observation(self) -> None:
        d = self.domain
        assemble({
            "base_ang_vel": self.base_ang_vel,
            "roll_pitch": torch.stack([self.roll, self.pitch], dim=-1),
            "delta_yaw": self.delta_yaw,
            "delta_next_yaw": self.delta_next_yaw,
            "command": self.command,
            "joint_pos": self.joint_pos - self.q_default,
            "joint_vel": self.joint_vel,
            "last_action": self.last_action,
            "foot_contact": self.contact_filt.float() - 0.5,
            "scandots": scandots(self.base_pos[:, 2], self.ground),
            "base_lin_vel": self.base_lin_vel,
            "added_mass": d.added_mass,
            "com_offset": d.com_offset,
            "friction": d.friction,
            "motor_strength_p": d.motor_strength[0] - 1.0,
            "motor_strength_d": d.motor_strength[1] - 1.0,
            "task_one_hot": self._one_hot,
        }, out=self._obs)

    # ------------------------------------------------------------------ resets
    def _place(self, mask: torch.Tensor) -> None:
        """Put the robots of ``mask`` on their tile (after the simulator reset them to ``qpos0``): base at the tile's
        spawn origin + 0.42 m, upright, joints at default + U(0, 0.9) rad, at rest; new speed command."""
        m = mask[:, None]
        tile_origin = self._tile_origin[self.level, self.column]
        offset = self._tile_offset[self.level, self.column]
        self.world_offset.copy_(torch.where(m, offset, self.world_offset))
        self.goals.copy_(torch.where(mask[:, None, None], self._tile_goals[self.level, self.column], self.goals))
        if self._geom_dataid is not None:
            self._geom_dataid.copy_(torch.where(mask, self._tile_hfield[self.level, self.column], self._geom_dataid))
        n = self.batch_size[0]
        base = tile_origin - offset + self._spawn_lift
        joints = self.q_default + self._uniform((n, ACTION_DIM), *RESET_JOINT_NOISE)
        qpos = torch.cat([base, self._upright, joints], dim=-1)
        self.sim.qpos.copy_(torch.where(m, qpos, self.sim.qpos))
        self.sim.qvel.copy_(torch.where(m, torch.zeros_like(self.sim.qvel), self.sim.qvel))
        self._sample_commands(mask)

    def _begin_episode(self, mask: torch.Tensor) -> None:
        """Clear the episode state of the worlds of ``mask`` and give them a fresh first observation state."""
        self.progress.masked_fill_(mask, 0)
        self.cur_goal_idx.masked_fill_(mask, 0)
        self.reach_timer.masked_fill_(mask, 0)
        self.last_action.masked_fill_(mask[:, None], 0.0)
        self.last_contacts.masked_fill_(mask[:, None], False)
        self.contact_filt.masked_fill_(mask[:, None], False)
        self._ep_return.masked_fill_(mask, 0.0)
        self._ep_counted |= mask
        self._read_state()
        self._set_targets(mask)
        self.ground.copy_(torch.where(mask[:, None], self._scan(), self.ground))

    def _refresh_yaw_deltas(self, refresh: torch.Tensor) -> None:
        self.delta_yaw.copy_(torch.where(refresh, self.target_yaw - self.yaw, self.delta_yaw))
        self.delta_next_yaw.copy_(torch.where(refresh, self.next_target_yaw - self.yaw, self.delta_next_yaw))

    # ------------------------------------------------------------------ the step, as four torch stages
    def _stage_action(self) -> None:
        """PD targets from the action; a NaN/inf component is replaced by 0 (and counted) before it can reach the
        physics or the observation."""
        finite = torch.isfinite(self._action_in)
        self._nonfinite_action.copy_(~finite.all(-1))
        action = torch.where(finite, self._action_in, torch.zeros_like(self._action_in))
        self.last_action.copy_(action)  # observed unclipped, as the original stores the raw action
        limit = robot.ACTION_CLIP / robot.ACTION_SCALE
        self.sim.ctrl.copy_(action.clamp(-limit, limit) * robot.ACTION_SCALE + self.q_default)

    def _stage_evaluate(self) -> None:
        """After physics: state, contacts, goals, commands, scandots, termination, reward, statistics, curriculum;
        stage the reset of finished worlds."""
        self.progress.add_(1)
        self.global_step.add_(1)
        self._read_state()
        contact = torch.linalg.vector_norm(self.body_contact_force[:, self.foot_bodies], dim=-1) > FOOT_CONTACT_FORCE
        self.contact_filt.copy_(contact | self.last_contacts)
        self.last_contacts.copy_(contact)
        self._update_goals()
        self._sample_commands(self.progress % COMMAND_RESAMPLE_STEPS == 0)
        refresh = (self.global_step % REFRESH_STEPS == 0).expand(self.batch_size[0])
        self.ground.copy_(torch.where(refresh[:, None], self._scan(), self.ground))

        unhealthy = self.sim.unhealthy()
        contact_overflow = self.sim.overflowed(HFIELD_OVERFLOW, clear=True)
        below = self.base_pos[:, 2] < MIN_BASE_Z
        rolled = self.roll.abs() > MAX_ROLL
        goals = self.cur_goal_idx >= NUM_GOALS
        fell = below | rolled | (self.pitch.abs() > MAX_PITCH)
        timeout = (self.progress >= self.max_episode_steps) | goals
        terminated = fell & ~unhealthy
        truncated = (timeout | unhealthy) & ~terminated
        done = terminated | truncated
        reward, terms = compute_reward(self, self.reward_scales, POLICY_DT, self.only_positive_rewards)
        reward = torch.where(torch.isfinite(reward) & ~unhealthy, reward, torch.zeros_like(reward))
        for name, value in terms.items():
            self.reward_terms[name].copy_(value)
        self._ep_return.add_(reward)
        ran_out = truncated & ~unhealthy  # all goals or the episode length
        ends = torch.stack([ran_out & goals, ran_out & ~goals, terminated & below, terminated & ~below & rolled,
                            terminated & ~below & ~rolled, unhealthy])
        self._accumulate_stats(done, unhealthy, contact_overflow, ends)
        if self.curriculum:
            new = cl.update_levels(self.level, self.cur_goal_idx, NUM_GOALS, self.num_rows,
                                   torch.rand(self.level.shape, generator=self._generator, device=self.device),
                                   torch.rand(self.level.shape, generator=self._generator, device=self.device))
            self.level.copy_(torch.where(done & ~unhealthy, new, self.level))
        self._reward.copy_(reward)
        self._terminated.copy_(terminated)
        self._truncated.copy_(truncated)
        self._done.copy_(done)
        self.sim.stage_reset(done)

    def _stage_place(self) -> None:
        self._place(self._done)

    def _stage_finish(self) -> None:
        """After the reset kinematics: first-step state of reset worlds, observation, then the periodic push."""
        done = self._done
        self._begin_episode(done)
        refresh = (self.global_step % REFRESH_STEPS == 0) | done
        self._refresh_yaw_deltas(refresh)
        self._observation()
        if self.push_robots:
            push = (self.global_step % PUSH_STEPS == 0) & ~done
            vel = self._uniform((self.batch_size[0], 2), -PUSH_VELOCITY, PUSH_VELOCITY)
            self.sim.qvel[:, 0:2] = torch.where(push[:, None], vel, self.sim.qvel[:, 0:2])

    def _accumulate_stats(self, done: torch.Tensor, unhealthy: torch.Tensor, contact_overflow: torch.Tensor,
                          ends: torch.Tensor) -> None:
        """Add this step's finished episodes to the per-task sums; ``ends`` ``[len(END_REASONS), N]`` bool: how
        each world's episode ended (one reason per finished world)."""
        counted = done & self._ep_counted
        c = counted.float()
        progress = self.cur_goal_idx.clamp(max=NUM_GOALS).float() / NUM_GOALS
        rows = torch.stack([c, c * progress, c * self._ep_return, c * self.progress.float(), unhealthy.float(),
                            c * self.level.float(), self._nonfinite_action.float(), contact_overflow.float(),
                            *(ends & counted).float()])
        self._stats.index_add_(1, self.task_id, rows)
        level = torch.where(counted, self.level, torch.full_like(self.level, -1))
        self._max_level.scatter_reduce_(0, self.task_id, level, reduce="amax")

    # ------------------------------------------------------------------ EnvBase API
    def _core_step(self, action: torch.Tensor) -> dict[str, torch.Tensor]:
        """One policy step of every world: PD targets, 4 physics steps, evaluation and autoreset of finished worlds.
        Branch-free tensor work, no host synchronisation."""
        act, evaluate, place, finish = self._stages
        self._action_in.copy_(action)
        sims = [self.sim]
        act()
        launch_all(sims, "step")
        evaluate()
        launch_all(sims, "reset")
        place()
        launch_all(sims, "kin")
        finish()
        return {"observation": self._obs.clone(), "reward": self._reward[:, None].clone(),
                "done": self._done[:, None].clone(), "terminated": self._terminated[:, None].clone(),
                "truncated": self._truncated[:, None].clone()}

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = checked_action(tensordict, self.batch_size[0], ACTION_DIM, "joint-position offsets, clipped to +-5")
        out = self._core_step(action)
        out["task_id"] = self.task_id
        return TensorDict(out, batch_size=self.batch_size, device=self.device)

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        n = self.batch_size[0]
        mask = reset_mask(tensordict, n, self.device)
        self.sim.reset(mask)
        self._place(mask)
        self.sim.kinematics()
        self._begin_episode(mask)
        self._refresh_yaw_deltas(mask)
        self._observation()
        if self.random_start_progress:
            start = torch.randint(0, self.max_episode_steps, (n,), generator=self._generator, device=self.device)
            self.progress.copy_(torch.where(mask, start, self.progress))
            self._ep_counted &= ~(mask & (start > 0))
        zeros = torch.zeros(n, 1, dtype=torch.bool, device=self.device)
        return TensorDict(
            {"observation": self._obs.clone(), "task_id": self.task_id.clone(), "done": zeros,
             "terminated": zeros.clone(), "truncated": zeros.clone()},
            batch_size=self.batch_size,
            device=self.device,
        )

    def _set_seed(self, seed: int | None) -> None:
        self._generator.manual_seed(0 if seed is None else int(seed))

    # ------------------------------------------------------------------ checkpointing
    _STATE = ("level", "world_offset", "goals", "command", "cur_goal_idx", "reach_timer", "target_pos_rel",
              "next_target_pos_rel", "target_yaw", "next_target_yaw", "delta_yaw", "delta_next_yaw", "ground",
              "last_action", "last_contacts", "contact_filt", "progress", "global_step", "_ep_return", "_ep_counted",
              "_stats", "_max_level")

    def get_extra_state(self) -> dict:
        """Everything needed to continue the exact same trajectories: episode state, curriculum levels, the RNG,
        the per-world domain randomization and the physics state (included in ``env.state_dict()``)."""
        return {
            "columns": list(self.columns),
            "column_counts": list(self.column_counts),
            "env": {k: getattr(self, k).clone() for k in self._STATE},
            "domain": {k: v.clone() for k, v in self.domain.tensors().items()},
            "generator": self._generator.get_state(),
            "sim": self.sim.get_state(),
        }

    def set_extra_state(self, state: dict) -> None:
        if state["columns"] != list(self.columns) or state["column_counts"] != list(self.column_counts):
            raise RuntimeError(f"env state is for columns {state['columns']} x {state['column_counts']}, this env has "
                               f"{list(self.columns)} x {list(self.column_counts)}")
        for k, v in state["env"].items():
            target = getattr(self, k)
            if k == "_stats" and v.shape[0] < target.shape[0]:  # saved before the end_* rows existed (2026-11-28)
                target.zero_()
                target[: v.shape[0]].copy_(v)
                continue
            target.copy_(v)
        for k, v in state["domain"].items():
            getattr(self.domain, k).copy_(v)
        self._generator.set_state(state["generator"].cpu() if self.device.type == "cpu" else state["generator"])
        self.sim.set_state(state["sim"])  # includes the batched model fields (domain randomization)
        self._read_state()

    # ------------------------------------------------------------------ statistics
    def exclude_episodes(self, mask: torch.Tensor) -> None:
        """Leave the current episodes of the worlds in ``mask`` ([N] bool) out of :meth:`pop_episode_stats` (their
        next episodes count again): an evaluation counting only the first episode of every world calls it after
        each step with the worlds that already finished one. No host synchronisation."""
        self._ep_counted &= ~mask.to(device=self.device, dtype=torch.bool).reshape(self._ep_counted.shape)

    def pop_episode_stats(self) -> TensorDict:
        """Per-task sums over the episodes finished since the last call (``[21]`` tensors on the env device):
        ``episodes``, ``success`` (summed progress = goals reached / 8, so ``success / episodes`` is the mean
        progress), ``return``, ``length``, ``unhealthy`` (worlds reset after a failed physics state),
        ``terrain_level`` (summed rows of the finished episodes), ``max_terrain_level`` (highest row of a finished
        episode, -1 if none), ``nonfinite_actions`` (steps whose action had a NaN/inf component, replaced by 0) and
        ``contact_overflow`` (steps in which a robot geom touched more than 50 heightfield prisms and kept the contacts
        of the first 50: the trunk lying on the ground; not a failure), and how the finished episodes ended, one
        reason each (so the six sum to ``episodes``): ``end_goals`` (all 8 goals reached), ``end_time`` (the episode
        length), ``end_height`` (base below -0.25 m: fell into a pit), ``end_roll`` (|roll| > 2.5, not below),
        ``end_pitch`` (|pitch| > 1.5, neither of those), ``end_physics`` (a failed physics state)."""
        stats = self._stats.clone()
        max_level = self._max_level.clone()
        self._stats.zero_()
        self._max_level.fill_(-1)
        out = {name: stats[i] for i, name in enumerate(STAT_ROWS)}
        out["max_terrain_level"] = max_level.float()
        return TensorDict(out, batch_size=[self.num_tasks])
