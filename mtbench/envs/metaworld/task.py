"""What a Meta-World task is in mtbench, and the named state its reward and success are functions of.

A task file under ``tasks/`` holds everything about one task: its scene (``scene``, ``edit_spec``), reset ranges
(``reset_low``/``reset_high``, ``reset``), the objects it reports in the observation (``objects``), its text
description (CARE's context), and its reward and success as pure functions of the named state in
:class:`TaskState` (object poses, TCP, finger pads, goal, initial positions, action), never of observation indices.
The env discovers the task files, runs one compiled model per task, and assembles observations with
:mod:`.observation`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, ClassVar, NamedTuple

import mujoco
import torch

from ...sim import WarpSim
from . import robot
from .scene import SceneSpec

# Meta-World's workspace for the hand (MTBench/Meta-World hand_low/hand_high), with the lower z bound at the table
# so that the Panda's fingertips can reach objects lying on it.
HAND_LOW = (-0.525, 0.348, 0.0)
HAND_HIGH = (0.525, 1.025, 0.7)

# ``paper``: the paper-era MTBench rewards, evaluated with the original's ``tolerance`` (0 inside its bounds: see
# ``reward_utils.mtbench_tolerance``), which reproduces the paper's tables; ``v2``: the same formulas with a correct
# ``tolerance`` (1 inside the bounds, Meta-World's), except for the tasks that redefine their v2 reward
# (``reward_v2``, ``success_reward_v2``): rewards of our design for the tasks that MT-PPO leaves at ~0% with the
# paper-era rewards (docs/metaworld.md, "reward_version v2"; docs/results/mt50_rand_ppo.md).
REWARD_VERSIONS: tuple[str, ...] = ("paper", "v2")
REWARD_REVISIONS: dict[str, str] = {"paper": "paper", "v2": "v2-2026-11-28g"}
"""The definition each reward version has in this code, recorded in logs and checkpoints (a run resumes only into
the same revision). ``v2`` revisions: ``v2-2026-11-25``, staged reach/grip/lift/carry rewards for the grasp-and-carry
tasks (the first MT50-rand v2 run); ``v2-2026-11-28``, pick_place's paper-era form with each task's grasp point and
path (``reward_utils.grasp_place_reward``) for basketball, box_close, disassemble, peg_insert_side,
pick_place_wall, push_wall and shelf_place (its MT50-rand run); ``v2-2026-11-28b``, the same plus door_close's reach
and linear closing reward (``tasks/door_close.py``; its MT50-rand run); ``v2-2026-11-28c``, the same plus stick_push
keeps its paper-era reward exactly, evaluated with the original ``tolerance`` (``tasks/stick_push.py``);
``v2-2026-11-28d``, the same plus pick_place_wall, push_wall and shelf_place pay the held object's speed along its
path (``grasp_place_reward``'s ``progress_speed``); ``v2-2026-11-28e``, the same plus door_open's reach target that
follows the door (the bar, then the panel's inner face) with linear pay for the angle (``tasks/door_open.py``) and
faucet_close's hand kept at the handle (``tasks/faucet_close.py``); ``v2-2026-11-28f``, the same plus basketball's
carry along a path that rises in front of the hoop, basketball and peg_insert_side paying the held object's
speed along its path, shelf_place's path turning in at its front point, and assembly in the grasp-and-carry form
(``tasks/assembly.py``); ``v2-2026-11-28g``, the same plus lever_pull's reach (under the ball) and linear lifting
reward (``tasks/lever_pull.py``)."""

Reward = Callable[["TaskState", torch.Tensor], torch.Tensor]


@dataclass
class TaskState:
    """Per-world state of one task block (``n`` worlds), read by the task's reward and success functions.

    The env refreshes ``tcp``, ``left_pad``, ``right_pad`` and the object poses (``obj_pos``, ``obj_quat``,
    ``obj2_pos``, ``obj2_quat``, from :meth:`MetaWorldTask.objects`) after every physics step and after resets;
    ``goal`` and ``obj_init_pos`` are written by the task's ``reset``; ``init_tcp`` and the ``init_*_pad`` positions
    are recorded after each reset. ``buffers`` holds the per-world tensors a task declares in
    :attr:`MetaWorldTask.buffers`. ``sim`` gives the raw simulator views (joint positions, sites, bodies).
    """

    sim: WarpSim
    n: int
    device: torch.device
    buffer_shapes: dict[str, tuple[int, ...]] = field(default_factory=dict)
    goal: torch.Tensor = field(init=False)
    obj_init_pos: torch.Tensor = field(init=False)
    init_tcp: torch.Tensor = field(init=False)
    init_left_pad: torch.Tensor = field(init=False)
    init_right_pad: torch.Tensor = field(init=False)
    tcp: torch.Tensor = field(init=False)
    left_pad: torch.Tensor = field(init=False)
    right_pad: torch.Tensor = field(init=False)
    obj_pos: torch.Tensor = field(init=False)
    obj_quat: torch.Tensor = field(init=False)
    obj2_pos: torch.Tensor = field(init=False)
    obj2_quat: torch.Tensor = field(init=False)
    buffers: dict[str, torch.Tensor] = field(init=False)

    POINTS: ClassVar[tuple[str, ...]] = ("goal", "obj_init_pos", "init_tcp", "init_left_pad", "init_right_pad", "tcp",
                                         "left_pad", "right_pad", "obj_pos", "obj2_pos")

    def __post_init__(self) -> None:
        for name in self.POINTS:
            setattr(self, name, torch.zeros(self.n, 3, device=self.device))
        self.obj_quat = torch.zeros(self.n, 4, device=self.device)
        self.obj2_quat = torch.zeros(self.n, 4, device=self.device)
        self.buffers = {k: torch.zeros(self.n, *shape, device=self.device) for k, shape in self.buffer_shapes.items()}

    @property
    def gripper_open(self) -> torch.Tensor:
        """Meta-World's ``obs[3]``: pad distance / 0.1 clipped to [0, 1] (1 = open), ``[n]``."""
        return ((self.right_pad - self.left_pad).norm(dim=-1) / 0.1).clamp(0.0, 1.0)

    # name kept for the reward helpers' Meta-World vocabulary
    gripper_distance_apart = gripper_open


class Objects(NamedTuple):
    """The objects a task reports in the observation: positions ``[n, 3]`` and wxyz quaternions ``[n, 4]``
    (``None``: reported as zeros, e.g. a handle point without orientation or no second object)."""

    pos: torch.Tensor
    quat: torch.Tensor | None = None
    pos2: torch.Tensor | None = None
    quat2: torch.Tensor | None = None


class MetaWorldTask:
    """Base class of a Meta-World task definition (one file per task under ``tasks/``).

    Subclasses set the class attributes and implement :meth:`reset`, :meth:`objects`, :meth:`reward` and
    :meth:`success`; the reward and success methods only gather named state and call the task file's pure
    functions of tensors (which the tests evaluate without physics).
    """

    name: ClassVar[str]
    mtbench_id: ClassVar[int]  # index in MTBench's TASK_IDX_TO_NAME: fixes the MT50 order and one-hot slots
    description: ClassVar[str]  # one sentence, embedded by CARE as the task's context
    scene: ClassVar[SceneSpec]
    # reset space: uniform sampling between low and high (object part then goal part)
    reset_low: ClassVar[tuple[float, ...]]
    reset_high: ClassVar[tuple[float, ...]]
    # per-world task buffers (name -> per-world shape), allocated in TaskState.buffers and checkpointed
    buffers: ClassVar[dict[str, tuple[int, ...]]] = {}
    # the dense reward is multiplied by this (the paper-era MTBench shaping factor) before reward_scale
    dense_scale: ClassVar[float] = 0.01
    success_bonus: ClassVar[float] = 10.0

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Optional task-specific edits of the scene spec before compilation (default: none)."""

    def __init__(self, model: mujoco.MjModel, device: torch.device | str = "cpu") -> None:
        self.model = model
        self.device = torch.device(device)
        self.left_pad_site = model.site(robot.LEFT_PAD).id
        self.right_pad_site = model.site(robot.RIGHT_PAD).id
        # constants live on the device: the env step may be captured in a CUDA graph, where creating tensors
        # from Python data (a host-to-device copy) is not allowed. Tasks must follow the same rule.
        self._reset_low = torch.tensor(self.reset_low, dtype=torch.float32, device=self.device)
        self._reset_high = torch.tensor(self.reset_high, dtype=torch.float32, device=self.device)
        self.bind(model)

    def new_state(self, sim: WarpSim, n: int) -> TaskState:
        """The per-world state of a block of ``n`` worlds of this task (with the task's buffers)."""
        return TaskState(sim=sim, n=n, device=self.device, buffer_shapes=dict(self.buffers))

    # ------------------------------------------------------------------ helpers for subclasses
    def bind(self, model: mujoco.MjModel) -> None:
        """Resolve model ids (bodies, sites, joints) the task uses and create its constant tensors on
        ``self.device`` (never create tensors from Python data in ``reset``/``reward``/``success``/``objects``)."""

    def const(self, values) -> torch.Tensor:
        """A float32 constant tensor on the task's device (for use in ``bind``)."""
        return torch.tensor(values, dtype=torch.float32, device=self.device)

    def joint_qposadr(self, name: str) -> int:
        return int(self.model.joint(name).qposadr[0])

    def body_qposadr(self, body: int) -> int:
        """``qpos`` address of the (first) joint of body ``body``, e.g. a free object's 7 position entries."""
        return int(self.model.jnt_qposadr[self.model.body_jntadr[body]])

    def body_dofadr(self, body: int) -> int:
        """``qvel`` address of the (first) joint of body ``body`` (:meth:`free_body_velocity`'s ``dofadr``)."""
        return int(self.model.jnt_dofadr[self.model.body_jntadr[body]])

    def body_id(self, name: str) -> int:
        return int(self.model.body(name).id)

    def site_id(self, name: str) -> int:
        return int(self.model.site(name).id)

    def sample(self, n: int, generator: torch.Generator, device: torch.device) -> torch.Tensor:
        """``n`` reset vectors drawn uniformly from the reset space."""
        u = torch.rand(n, self._reset_low.numel(), generator=generator, device=device)
        return self._reset_low + u * (self._reset_high - self._reset_low)

    @staticmethod
    def set_free_body(sim: WarpSim, qposadr: int, pos: torch.Tensor, mask: torch.Tensor,
                      quat: torch.Tensor | None = None) -> None:
        """Place a free-joint body at ``pos`` (and ``quat``, wxyz) in the worlds of ``mask`` (its position only: at a
        reset the simulator's keyframe reset, which runs first, has zeroed the velocities)."""
        q = sim.qpos[:, qposadr:qposadr + 7]
        new = torch.cat([pos, quat if quat is not None else unit_quat(pos)], dim=-1)
        q.copy_(torch.where(mask[:, None], new, q))

    @staticmethod
    def free_body_velocity(sim: WarpSim, dofadr: int) -> torch.Tensor:
        """Linear velocity ``[n, 3]`` (m/s, world frame) of a free-joint body's origin: its joint's first three
        velocity components, from the joint's velocity address ``dofadr``."""
        return sim.qvel[:, dofadr:dofadr + 3]

    @staticmethod
    def set_body_pos(sim: WarpSim, body: int, pos: torch.Tensor, mask: torch.Tensor) -> None:
        """Move a world-fixed body, e.g. a drawer cabinet, per world (its fixed geoms move with it)."""
        sim.set_body_pos(body, pos, mask)

    @staticmethod
    def set_joint(sim: WarpSim, qposadr: int, value: float | torch.Tensor, mask: torch.Tensor) -> None:
        """Set a 1-dof joint position in the worlds of ``mask`` (its velocity is zero after the robot reset)."""
        q = sim.qpos[:, qposadr]
        q.copy_(torch.where(mask, value, q))

    @staticmethod
    def masked_set(dst: torch.Tensor, value: torch.Tensor, mask: torch.Tensor) -> None:
        """``dst[mask] = value[mask]`` for per-world tensors ``[n, ...]``, without indexing (graph friendly)."""
        m = mask.reshape(mask.shape + (1,) * (dst.dim() - 1))
        dst.copy_(torch.where(m, value, dst))

    def body_pose(self, s: TaskState, body: int) -> tuple[torch.Tensor, torch.Tensor]:
        """World position and wxyz orientation of a body ``([n, 3], [n, 4])``."""
        return s.sim.xpos[:, body], s.sim.xquat[:, body]

    # ------------------------------------------------------------------ task interface
    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        """Write the initial object state for the worlds in ``mask`` from reset vectors ``vec`` and set
        ``s.goal`` / ``s.obj_init_pos`` (and task buffers) there. Called after the robot was reset."""
        raise NotImplementedError(f"task {self.name!r} does not define reset()")

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        """Record quantities measured in the reset state (kinematics and object poses are fresh here)."""

    def objects(self, s: TaskState) -> Objects:
        """The poses of the objects this task reports in the observation."""
        raise NotImplementedError(f"task {self.name!r} does not define objects()")

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        """The paper-era dense reward ``[n]`` on the task's own scale (the env multiplies it by ``dense_scale``
        and ``reward_scale``). In ``reward_version="paper"`` the env evaluates it under
        :func:`~.reward_utils.mtbench_tolerance`, in ``"v2"`` with the correct ``tolerance``."""
        raise NotImplementedError(f"task {self.name!r} does not define reward()")

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        """The ``reward_version="v2"`` dense reward: the paper-era formula with the correct ``tolerance`` unless
        the task redefines it."""
        return self.reward(s, action)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        """The paper-era MTBench success rule ``[n]`` bool (the same in every reward version)."""
        raise NotImplementedError(f"task {self.name!r} does not define success()")

    def success_reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        """The reward ``[n]`` paid on steps where :meth:`success` holds (not scaled by ``reward_scale``): the
        constant ``success_bonus`` (MTBench: 10, or 20 for a few tasks)."""
        return s.tcp.new_full((s.n,), self.success_bonus)

    def success_reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        """The reward on success steps in ``reward_version="v2"``: :meth:`success_reward` unless the task
        redefines it."""
        return self.success_reward(s, action)

    def dense_reward(self, version: str) -> Reward:
        """The dense-reward function of a reward version (``REWARD_VERSIONS``)."""
        check_reward_version(version)
        return self.reward if version == "paper" else self.reward_v2

    def success_reward_fn(self, version: str) -> Reward:
        """The success-step reward function of a reward version (``REWARD_VERSIONS``)."""
        check_reward_version(version)
        return self.success_reward if version == "paper" else self.success_reward_v2

    @classmethod
    def has_v2_reward(cls) -> bool:
        """True if the task redefines its reward in ``reward_version="v2"``."""
        return cls.reward_v2 is not MetaWorldTask.reward_v2

    # ------------------------------------------------------------------ used by the env
    def refresh_objects(self, s: TaskState) -> None:
        """Copy the current :meth:`objects` into ``s.obj_pos``/``obj_quat``/``obj2_pos``/``obj2_quat``."""
        objs = self.objects(s)
        s.obj_pos.copy_(objs.pos)
        for dst, value in ((s.obj_quat, objs.quat), (s.obj2_pos, objs.pos2), (s.obj2_quat, objs.quat2)):
            if value is not None:
                dst.copy_(value)


class FreeObjectTask(MetaWorldTask):
    """A task with one free object (Meta-World's body ``obj`` on joint ``objjoint``) and a goal. Reset vector:
    object xyz then goal xyz; goals closer than ``MIN_GOAL_DIST`` (in xy) to the object are resampled, as
    Meta-World does (a fixed number of rounds: no data-dependent loop)."""

    MIN_GOAL_DIST: ClassVar[float] = 0.15
    OBJ_BODY: ClassVar[str] = "obj"
    OBJ_JOINT: ClassVar[str] = "objjoint"

    def bind(self, model: mujoco.MjModel) -> None:
        self.obj_qpos = self.joint_qposadr(self.OBJ_JOINT)
        self.obj_dof = int(model.joint(self.OBJ_JOINT).dofadr[0])
        self.obj_body = self.body_id(self.OBJ_BODY)

    def object_velocity(self, s: TaskState) -> torch.Tensor:
        """Linear velocity ``[n, 3]`` (m/s, world frame) of the object body's origin (its free joint's first three
        velocity components)."""
        return self.free_body_velocity(s.sim, self.obj_dof)

    def sample(self, n: int, generator: torch.Generator, device: torch.device) -> torch.Tensor:
        vec = super().sample(n, generator, device)
        for _ in range(8):
            close = (vec[:, :2] - vec[:, 3:5]).norm(dim=-1) < self.MIN_GOAL_DIST
            vec = torch.where(close[:, None], super().sample(n, generator, device), vec)
        return vec

    def place(self, s: TaskState, obj: torch.Tensor, goal: torch.Tensor, mask: torch.Tensor) -> None:
        """Put the object at ``obj`` and the goal at ``goal`` in the worlds of ``mask``."""
        self.set_free_body(s.sim, self.obj_qpos, obj, mask)
        self.masked_set(s.obj_init_pos, obj, mask)
        self.masked_set(s.goal, goal, mask)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.place(s, vec[:, :3], vec[:, 3:6], mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(*self.body_pose(s, self.obj_body))


def check_reward_version(version: str) -> None:
    """Raise ``ValueError`` naming ``reward_version`` and its valid choices unless ``version`` is one of them."""
    if version not in REWARD_VERSIONS:
        raise ValueError(f"unknown reward_version {version!r}; valid choices: {list(REWARD_VERSIONS)}")


def unit_quat(like: torch.Tensor) -> torch.Tensor:
    """Identity quaternions (wxyz) ``[..., 4]`` (built without writing a Python number into a tensor, which
    would be a host-to-device copy inside a CUDA graph capture)."""
    return torch.nn.functional.pad(like.new_ones(*like.shape[:-1], 1), (0, 3))


def offset(x: torch.Tensor, dx: float, dy: float, dz: float) -> torch.Tensor:
    """``x + (dx, dy, dz)`` for points ``[..., 3]`` with the constant as Python floats (no host-to-device copy)."""
    return torch.stack([x[..., 0] + dx, x[..., 1] + dy, x[..., 2] + dz], dim=-1)


__all__ = ["HAND_HIGH", "HAND_LOW", "REWARD_REVISIONS", "REWARD_VERSIONS", "check_reward_version", "FreeObjectTask",
           "MetaWorldTask", "Objects", "TaskState", "offset", "unit_quat"]
