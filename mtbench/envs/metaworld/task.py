"""What a Meta-World task is in mtbench: a scene, reset ranges, an observation of its objects, a reward and a
success rule, all over batched torch tensors of one block of worlds (one compiled model per task)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import mujoco
import torch

from ...sim import WarpSim
from . import robot
from .scene import SceneSpec

# Meta-World's workspace for the hand (MTBench/Meta-World hand_low/hand_high), with the lower z bound at the table
# so that the Panda's fingertips can reach objects lying on it.
HAND_LOW = (-0.525, 0.348, 0.0)
HAND_HIGH = (0.525, 1.025, 0.7)


@dataclass
class TaskState:
    """Per-world buffers of one task block. Sizes are ``n`` = number of worlds of the block.

    The env refreshes ``tcp``, ``left_pad``, ``right_pad`` after every physics step; tasks read them (and the
    simulator views in ``sim``) to build object observations, rewards and success.
    """

    sim: WarpSim
    n: int
    device: torch.device
    goal: torch.Tensor = field(init=False)
    obj_init_pos: torch.Tensor = field(init=False)
    init_tcp: torch.Tensor = field(init=False)
    init_left_pad: torch.Tensor = field(init=False)
    init_right_pad: torch.Tensor = field(init=False)
    tcp: torch.Tensor = field(init=False)
    left_pad: torch.Tensor = field(init=False)
    right_pad: torch.Tensor = field(init=False)
    extra: dict[str, torch.Tensor] = field(default_factory=dict)

    def __post_init__(self) -> None:
        z = lambda: torch.zeros(self.n, 3, device=self.device)  # noqa: E731
        self.goal, self.obj_init_pos, self.init_tcp = z(), z(), z()
        self.init_left_pad, self.init_right_pad = z(), z()
        self.tcp, self.left_pad, self.right_pad = z(), z(), z()

    @property
    def gripper_distance_apart(self) -> torch.Tensor:
        """Meta-World's ``obs[3]``: pad distance / 0.1 clipped to [0, 1] (1 = open)."""
        return ((self.right_pad - self.left_pad).norm(dim=-1) / 0.1).clamp(0.0, 1.0)


class MetaWorldTask:
    """Base class of a Meta-World task definition. Subclasses set the class attributes and implement
    :meth:`reset`, :meth:`object_state` and :meth:`evaluate`."""

    name: ClassVar[str]
    scene: ClassVar[SceneSpec]
    # reset space: uniform sampling between low and high (object part then goal part)
    reset_low: ClassVar[tuple[float, ...]]
    reset_high: ClassVar[tuple[float, ...]]
    # dense Meta-World reward is multiplied by this (the paper-era MTBench shaping factor) before reward_scale
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

    # ------------------------------------------------------------------ helpers for subclasses
    def bind(self, model: mujoco.MjModel) -> None:
        """Resolve model ids (bodies, sites, joints) the task uses and create its constant tensors on
        ``self.device`` (never create tensors from Python data in ``reset``/``evaluate``/``object_state``)."""

    def const(self, values) -> torch.Tensor:
        """A float32 constant tensor on the task's device (for use in ``bind``)."""
        return torch.tensor(values, dtype=torch.float32, device=self.device)

    def joint_qposadr(self, name: str) -> int:
        return int(self.model.joint(name).qposadr[0])

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
        """Place a free-joint body at ``pos`` (and ``quat``, wxyz) in the worlds of ``mask``; zero its velocity."""
        q = sim.qpos[:, qposadr:qposadr + 7]
        new = torch.cat([pos, quat if quat is not None else _unit_quat(pos)], dim=-1)
        q.copy_(torch.where(mask[:, None], new, q))

    @staticmethod
    def set_body_pos(sim: WarpSim, body: int, pos: torch.Tensor, mask: torch.Tensor) -> None:
        """Move a world-fixed body, e.g. a drawer cabinet, per world (its fixed geoms move with it)."""
        sim.set_body_pos(body, pos, mask)

    # ------------------------------------------------------------------ task interface
    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        """Write the initial object state for the worlds in ``mask`` from reset vectors ``vec`` and set
        ``s.goal`` / ``s.obj_init_pos`` (and task buffers) there. Called after the robot was reset."""
        raise NotImplementedError

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        """Record quantities measured in the reset state (kinematics are fresh here)."""

    def object_state(self, s: TaskState) -> torch.Tensor:
        """``[n, 14]``: object 1 position + quaternion (wxyz), object 2 position + quaternion (zeros if none)."""
        raise NotImplementedError

    def evaluate(self, s: TaskState, action: torch.Tensor, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Return the dense Meta-World v2 reward ``[n]`` (its own scale, before ``dense_scale``) and success
        ``[n]`` bool (the paper-era MTBench success rule)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ common observation pieces
    def body_pose(self, s: TaskState, body: int) -> torch.Tensor:
        return torch.cat([s.sim.xpos[:, body], s.sim.xquat[:, body]], dim=-1)


class FreeObjectTask(MetaWorldTask):
    """A task with one free object (Meta-World's body ``obj`` on joint ``objjoint``) and a goal. Reset vector:
    object xyz then goal xyz; goals closer than ``MIN_GOAL_DIST`` (in xy) to the object are resampled, as
    Meta-World does (a fixed number of rounds: no data-dependent loop)."""

    MIN_GOAL_DIST: ClassVar[float] = 0.15

    def bind(self, model: mujoco.MjModel) -> None:
        self.obj_qpos = self.joint_qposadr("objjoint")
        self.obj_body = self.body_id("obj")

    def sample(self, n: int, generator: torch.Generator, device: torch.device) -> torch.Tensor:
        vec = super().sample(n, generator, device)
        for _ in range(8):
            close = (vec[:, :2] - vec[:, 3:5]).norm(dim=-1) < self.MIN_GOAL_DIST
            vec = torch.where(close[:, None], super().sample(n, generator, device), vec)
        return vec

    def place(self, s: TaskState, obj: torch.Tensor, goal: torch.Tensor, mask: torch.Tensor) -> None:
        """Put the object at ``obj`` and the goal at ``goal`` in the worlds of ``mask``."""
        self.set_free_body(s.sim, self.obj_qpos, obj, mask)
        s.obj_init_pos.copy_(torch.where(mask[:, None], obj, s.obj_init_pos))
        s.goal.copy_(torch.where(mask[:, None], goal, s.goal))

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.place(s, vec[:, :3], vec[:, 3:6], mask)

    def object_state(self, s: TaskState) -> torch.Tensor:
        return pad_object_state(self.body_pose(s, self.obj_body))


def _unit_quat(like: torch.Tensor) -> torch.Tensor:
    """Identity quaternions (wxyz) ``[..., 4]`` (built without writing a Python number into a tensor, which
    would be a host-to-device copy inside a CUDA graph capture)."""
    return torch.nn.functional.pad(like.new_ones(*like.shape[:-1], 1), (0, 3))


def pad_object_state(first: torch.Tensor, second: torch.Tensor | None = None) -> torch.Tensor:
    """Concatenate one or two 7-d poses into Meta-World's 14-d padded object state."""
    if second is None:
        second = torch.zeros_like(first)
    return torch.cat([first, second], dim=-1)
