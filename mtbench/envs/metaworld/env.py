"""The batched Meta-World multi-task environment (TorchRL ``EnvBase``) on MuJoCo Warp."""

from __future__ import annotations

import functools
from typing import Callable, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

from ...sim import WarpSim, WarpSimSlice, launch_all, warp_device
from ...utils import GraphedStage
from ..inputs import checked_action, reset_mask
from . import observation as layout
from . import robot
from .models import compiled_task, physics_groups
from .reward_utils import mtbench_tolerance
from .task import HAND_HIGH, HAND_LOW, REWARD_REVISIONS, MetaWorldTask, Reward, TaskState, check_reward_version

STATE_DIM = layout.STATE_DIM
ACTION_DIM = 4


class MetaWorldEnv(EnvBase):
    """Meta-World manipulation tasks on a Franka Panda, ``sum(task_counts)`` worlds in contiguous task blocks.

    Each task is its own MuJoCo Warp model (one kinematic tree per batch); on the GPU the blocks step
    concurrently on separate CUDA streams, each block's physics as a captured CUDA graph.

    Observation: Meta-World's 39-d layout (:mod:`.observation`: ``[tcp(3), gripper_open(1), obj1 pos+quat(7),
    obj2 pos+quat(7), previous 18-d frame, goal(3)]``) followed by the one-hot task id (``K`` dims). Quaternions
    are MuJoCo's wxyz. Action: ``[-1, 1]^4``: TCP displacement (``action_scale`` m per step at full scale)
    and gripper effort (+1 closes). Reward (paper-era MTBench): ``task.success_reward`` (the task's bonus, 10 or 20)
    on steps where the task is solved, otherwise the task's dense reward times ``task.dense_scale`` (0.01) times
    ``reward_scale``. Episodes last
    ``episode_length`` steps and end by truncation only; the env resets finished worlds itself (TorchRL native
    autoreset) and returns the first observation of the next episode.

    Args:
        tasks: task names (see ``mtbench.envs.metaworld.TASKS``).
        task_counts: worlds per task (contiguous blocks in this order).
        device: torch device; the physics runs on the matching Warp device.
        seed: seed of the env's random generator (reset sampling).
        rand: True: resample object/goal positions at every reset ("-rand" settings). False: each world samples
            them once and keeps them ("fixed", MTBench's default).
        reward_scale: multiplier of the dense reward on non-success steps (100 in the paper's runs).
        episode_length: steps per episode (150).
        substeps: physics steps per control step (``control dt = substeps * timestep``).
        random_start_progress: start each world at a random step of its first episode so that resets are spread
            over time (MTBench's ``init_at_random_progress``); the first, shortened episode of each world is
            not counted in the episode statistics.
        nconmax, njmax: contact / constraint buffer sizes per world.
        use_graph: capture physics as graphs (CUDA graphs on the GPU, Warp CPU graphs on the CPU).
        parallel_streams: on the GPU, run the task blocks' physics concurrently on one CUDA stream each.
        torch_graphs: on the GPU, capture the env's torch work (action, observation, reward, success,
            statistics, autoreset) in four CUDA graphs replayed between the physics launches, after
            ``graph_warmup`` eager steps. Without them a step issues ~1000 small kernels from Python and is
            host-bound.
        graph_warmup: eager steps before the torch work is captured.
        compile_stages: ``torch.compile`` the torch stages (Inductor fuses each task's element-wise reward,
            success and observation code into a few kernels; the reset draws stay eager, as ``torch.compile``
            does not trace a ``torch.Generator``). With 50 tasks a step's torch work is ~15,000 torch ops (views included);
            compiled, MT50-rand's reward/observation stage takes 1.2 ms instead of 17.4 on an H200 and the env
            step 24.5 ms instead of 43.8 (docs/benchmarks.md §6). Compiles at the first step (MT50: ~5 minutes
            on the GPU host; Inductor caches it on disk for later runs). Same results up to float rounding.
            ``"auto"``: on for a CUDA device, off on the CPU (what conf/env/mt50*.yaml select).
        robot_collision: hand and finger collision geometry, ``"primitive"`` (boxes fitted to the Panda's
            collision meshes; much cheaper contacts on the GPU) or ``"mesh"`` (Menagerie's convex meshes).
        box_box_collider: ``"primitive"`` (MuJoCo C's box-box routine) or ``"gjk"`` (MuJoCo Warp's default
            GJK/EPA); see :class:`~mtbench.sim.WarpSim`.
        reward_version: ``"paper"`` (the paper-era MTBench rewards with the original's ``tolerance``, default) or
            ``"v2"`` (Meta-World's correct ``tolerance``, and rewards of our design for the tasks that define
            ``reward_v2``; see ``docs/metaworld.md``).
        action_scale: metres of TCP displacement per control step at ``|action| = 1`` (``robot.ACTION_SCALE`` =
            0.01, Meta-World's; MTBench's discrete-action PQN runs use 0.005).
        group_models: let tasks whose compiled models share every field MuJoCo Warp cannot batch per
            world (:func:`~.models.strict_signature`, checked by :func:`~mtbench.sim.groupable`) share one
            :class:`~mtbench.sim.WarpSim` (fewer, larger physics blocks; each task's differing fields and keyframe
            are per world). ``env.blocks[i][1].sim`` is then a :class:`~mtbench.sim.WarpSimSlice`; ``env.sims``
            lists the distinct sims. Off (default): one sim per task.
    """

    _torchrl_native_autoreset = True

    def __init__(
        self,
        tasks: Sequence[str],
        task_counts: Sequence[int],
        *,
        device: torch.device | str = "cpu",
        seed: int = 0,
        rand: bool = True,
        reward_scale: float = 100.0,
        episode_length: int = 150,
        substeps: int = 3,
        random_start_progress: bool = True,
        nconmax: int | None = 96,
        njmax: int | None = 320,
        use_graph: bool = True,
        parallel_streams: bool = True,
        torch_graphs: bool = True,
        graph_warmup: int = 2,
        compile_stages: bool | str = False,
        robot_collision: str = "primitive",
        box_box_collider: str = "primitive",
        reward_version: str = "paper",
        action_scale: float = robot.ACTION_SCALE,
        group_models: bool = False,
    ) -> None:
        tasks = list(tasks)
        counts = [int(c) for c in task_counts]
        if len(tasks) != len(counts):
            raise ValueError(f"{len(tasks)} tasks but {len(counts)} task_counts; give one count per task")
        if any(c < 1 for c in counts):
            raise ValueError(f"task_counts must all be positive, got {counts}")
        if len(set(tasks)) != len(tasks):
            raise ValueError(f"task names must be unique, got {tasks}")
        check_reward_version(reward_version)
        if episode_length < 1:
            raise ValueError(f"episode_length must be positive, got {episode_length}")
        if not (isinstance(action_scale, (int, float)) and not isinstance(action_scale, bool) and action_scale > 0):
            raise ValueError(f"action_scale must be a number > 0 (metres per control step at |action| = 1); got "
                             f"{action_scale!r}")
        num_envs = sum(counts)
        warp_device(device)  # clear error for an unavailable device, before torch touches it
        super().__init__(device=device, batch_size=torch.Size([num_envs]))
        # TorchRL looks the flag up on the instance: without it, it would reset finished worlds a second time
        self.__dict__["_torchrl_native_autoreset"] = True
        dev = self.device
        self.task_names = tasks
        self.reward_version = reward_version
        self.reward_revision = REWARD_REVISIONS[reward_version]  # the definition in this code (task.py)
        self.task_counts = counts
        self.num_tasks = len(tasks)
        self.state_dim = STATE_DIM
        self.max_episode_steps = episode_length
        self.rand = rand
        self.reward_scale = float(reward_scale)
        self.action_scale = float(action_scale)
        self.random_start_progress = random_start_progress
        self._generator = torch.Generator(device=dev)
        self._generator.manual_seed(seed)
        self.blocks: list[tuple[MetaWorldTask, TaskState]] = []
        self._dense_rewards: list[Reward] = []
        self._success_rewards: list[Reward] = []
        self.slices: list[slice] = []
        if not isinstance(group_models, bool):
            raise ValueError(f"group_models must be True or False; got {group_models!r}")
        self.group_models = group_models
        task_models = [compiled_task(name, robot_collision) for name in tasks]
        #: task indices of each physics block (one WarpSim each): one task per block unless ``group_models``
        self.model_groups: list[list[int]] = physics_groups([m for _, m in task_models]) if group_models else [
            [i] for i in range(len(tasks))]
        sims: list[WarpSim] = []
        # each sim's worlds in the env's world order: a slice when its tasks are adjacent, else an index tensor
        self._sim_worlds: list[slice | torch.Tensor] = []
        task_sims: list[WarpSim | WarpSimSlice | None] = [None] * len(tasks)
        task_start = [sum(counts[:i]) for i in range(len(tasks))]
        for group in self.model_groups:
            mjm = task_models[group[0]][1]
            n = sum(counts[i] for i in group)
            world_models = [(task_models[i][1], counts[i]) for i in group] if len(group) > 1 else None
            sim = WarpSim(mjm, n, dev, substeps=substeps, nconmax=nconmax, njmax=njmax,
                          batched_fields=("body_pos",), use_graph=use_graph,
                          box_box_collider=box_box_collider, world_models=world_models)
            sims.append(sim)
            if group == list(range(group[0], group[0] + len(group))):
                self._sim_worlds.append(slice(task_start[group[0]], task_start[group[0]] + n))
            else:
                self._sim_worlds.append(torch.cat([torch.arange(task_start[i], task_start[i] + counts[i])
                                                   for i in group]).to(dev))
            offset = 0
            for i in group:
                task_sims[i] = sim if world_models is None else WarpSimSlice(sim, offset, offset + counts[i])
                offset += counts[i]
        start = 0
        for (task_cls, mjm), count, sim in zip(task_models, counts, task_sims):
            task = task_cls(mjm, dev)
            self.blocks.append((task, task.new_state(sim, count)))
            self._dense_rewards.append(task.dense_reward(reward_version))
            self._success_rewards.append(task.success_reward_fn(reward_version))
            self.slices.append(slice(start, start + count))
            start += count
        self.task_id = torch.repeat_interleave(torch.arange(self.num_tasks, device=dev),
                                               torch.tensor(counts, device=dev))
        self._one_hot = torch.nn.functional.one_hot(self.task_id, self.num_tasks).float()
        self.task_descriptions = [task.description for task, _ in self.blocks]
        hand_offset = torch.tensor([0.0, 0.0, robot.TCP_OFFSET], device=dev)
        self._mocap_low = torch.tensor(HAND_LOW, device=dev) + hand_offset
        self._mocap_high = torch.tensor(HAND_HIGH, device=dev) + hand_offset
        # per-world episode state (updated in place: the step may be replayed from a CUDA graph)
        self._step_count = torch.zeros(num_envs, dtype=torch.long, device=dev)
        self._ep_return = torch.zeros(num_envs, device=dev)
        self._ep_success = torch.zeros(num_envs, dtype=torch.bool, device=dev)
        self._ep_counted = torch.ones(num_envs, dtype=torch.bool, device=dev)
        self._prev_frame = torch.zeros(num_envs, 18, device=dev)
        self._reset_vec = [task.sample(s.n, self._generator, dev) for task, s in self.blocks]
        self._vec_sampled = torch.zeros(num_envs, dtype=torch.bool, device=dev)
        # per task: episodes, success, return, length, unhealthy, nonfinite_actions
        self._stats = torch.zeros(len(self.STAT_KEYS), self.num_tasks, device=dev)
        self._nonfinite_action = torch.zeros(num_envs, dtype=torch.bool, device=dev)
        self._parallel_streams = parallel_streams
        # step buffers: the stages below communicate only through these (the stages may be CUDA graphs)
        self._action_in = torch.zeros(num_envs, ACTION_DIM, device=dev)
        self._action = torch.zeros(num_envs, ACTION_DIM, device=dev)
        self._frame = torch.zeros(num_envs, 18, device=dev)
        self._reward = torch.zeros(num_envs, device=dev)
        self._done = torch.zeros(num_envs, dtype=torch.bool, device=dev)
        self._obs = torch.zeros(num_envs, STATE_DIM + self.num_tasks, device=dev)
        self._sims = sims
        enabled = torch_graphs and dev.type == "cuda"
        pool = torch.cuda.graph_pool_handle() if enabled else None
        stream = torch.cuda.Stream(device=dev) if enabled else None
        stage = dict(device=dev, warmup=graph_warmup, pool=pool, stream=stream, enabled=enabled)
        if not (isinstance(compile_stages, bool) or compile_stages == "auto"):
            raise ValueError(f"compile_stages must be True, False or 'auto'; got {compile_stages!r}")
        if compile_stages == "auto":
            compile_stages = dev.type == "cuda"
        self.compile_stages = compile_stages
        compiled = torch.compile if compile_stages else (lambda fn: fn)
        self._apply_reset_samples = compiled(self._apply_reset_samples)
        self._stages = (
            GraphedStage(compiled(self._stage_action), name="action", **stage),
            GraphedStage(compiled(self._stage_evaluate), name="evaluate", **stage),
            GraphedStage(self._stage_place_objects, name="place_objects", generators=(self._generator,), **stage),
            GraphedStage(compiled(self._stage_finish), name="finish", **stage),
        )
        act, evaluate, place, finish = self._stages
        streams = dict(parallel_streams=parallel_streams)
        #: the parts of a step, in order (what :meth:`_core_step` runs; benchmarks/env_throughput.py times them)
        self.step_parts: tuple[tuple[str, Callable[[], None]], ...] = (
            ("torch: action", act),
            ("physics: step", functools.partial(launch_all, self._sims, "step", **streams)),
            ("torch: evaluate", evaluate),
            ("physics: reset", functools.partial(launch_all, self._sims, "reset", **streams)),
            ("torch: place objects", place),
            ("physics: kinematics", functools.partial(launch_all, self._sims, "kin", **streams)),
            ("torch: finish", finish),
        )
        self._make_specs()

    # ------------------------------------------------------------------ specs
    def _make_specs(self) -> None:
        n, dev, k = self.batch_size[0], self.device, self.num_tasks
        self.observation_spec = Composite(
            observation=Unbounded(shape=(n, STATE_DIM + k), device=dev),
            task_id=Categorical(k, shape=(n,), dtype=torch.long, device=dev),
            shape=(n,),
            device=dev,
        )
        self.action_spec = Bounded(-1.0, 1.0, shape=(n, ACTION_DIM), device=dev)
        self.reward_spec = Unbounded(shape=(n, 1), device=dev)
        done = Categorical(2, shape=(n, 1), dtype=torch.bool, device=dev)
        self.full_done_spec = Composite(done=done.clone(), terminated=done.clone(), truncated=done.clone(),
                                        shape=(n,), device=dev)

    @property
    def sims(self) -> list[WarpSim]:
        """The distinct physics blocks (one per task unless ``group_models``), in the order of their first task."""
        return list(self._sims)

    # ------------------------------------------------------------------ internals
    def _refresh_kinematic_quantities(self) -> None:
        for task, s in self.blocks:
            s.left_pad.copy_(s.sim.site_xpos[:, task.left_pad_site])
            s.right_pad.copy_(s.sim.site_xpos[:, task.right_pad_site])
            s.tcp.copy_(0.5 * (s.left_pad + s.right_pad))
            task.refresh_objects(s)

    def _frames(self) -> torch.Tensor:
        """``[N, 18]`` current frame ``[tcp, gripper_open, objects]`` of every world."""
        parts = [layout.frame(s.tcp, s.gripper_open, s.obj_pos, s.obj_quat, s.obj2_pos, s.obj2_quat)
                 for _, s in self.blocks]
        return torch.cat(parts, dim=0)

    def _goals(self) -> torch.Tensor:
        return torch.cat([s.goal for _, s in self.blocks], dim=0)

    def _observation(self, frame: torch.Tensor, prev_frame: torch.Tensor) -> torch.Tensor:
        return layout.compose(frame, prev_frame, self._goals(), self._one_hot)

    # A reset of the worlds in ``mask``: stage the robot reset (torch) -> launch the keyframe reset (Warp) ->
    # place objects and goals (torch) -> launch kinematics (Warp) -> record the reset state (torch).
    def _stage_resets(self, mask: torch.Tensor) -> None:
        for sim, worlds in zip(self._sims, self._sim_worlds):
            sim.stage_reset(mask[worlds])

    def _place_objects(self, mask: torch.Tensor) -> None:
        """Objects and goals of the worlds in ``mask``: resampled ("-rand") or each world's first sample."""
        self._apply_reset_samples(mask, self._draw_reset_samples())

    def _draw_reset_samples(self) -> list[torch.Tensor]:
        """A fresh reset vector for every world, block by block (the env generator's draws)."""
        return [task.sample(s.n, self._generator, self.device) for task, s in self.blocks]

    def _apply_reset_samples(self, mask: torch.Tensor, samples: list[torch.Tensor]) -> None:
        """Place objects and goals of the worlds in ``mask`` from ``samples`` (or each world's first sample)."""
        for b, ((task, s), sl, new) in enumerate(zip(self.blocks, self.slices, samples)):
            m = mask[sl]
            keep = torch.zeros_like(m) if self.rand else self._vec_sampled[sl]
            vec = torch.where(keep[:, None], self._reset_vec[b], new)
            self._reset_vec[b].copy_(torch.where(m[:, None], vec, self._reset_vec[b]))
            task.reset(s, vec, m)
        self._vec_sampled |= mask

    def _record_reset(self, mask: torch.Tensor) -> None:
        self._refresh_kinematic_quantities()
        for (task, s), sl in zip(self.blocks, self.slices):
            m = mask[sl][:, None]
            s.init_tcp.copy_(torch.where(m, s.tcp, s.init_tcp))
            s.init_left_pad.copy_(torch.where(m, s.left_pad, s.init_left_pad))
            s.init_right_pad.copy_(torch.where(m, s.right_pad, s.init_right_pad))
            task.after_reset(s, mask[sl])

    def _reset_worlds(self, mask: torch.Tensor) -> None:
        """Reset the worlds in ``mask`` (robot to its home pose, objects/goals resampled or kept)."""
        self._stage_resets(mask)
        launch_all(self._sims, "reset", parallel_streams=self._parallel_streams)
        self._place_objects(mask)
        launch_all(self._sims, "kin", parallel_streams=self._parallel_streams)
        self._record_reset(mask)

    def _apply_action(self, action: torch.Tensor) -> None:
        """Move each world's mocap target by the (already clamped) action and set the gripper force."""
        for (task, s), sl in zip(self.blocks, self.slices):
            a = action[sl]
            mocap = s.sim.mocap_pos[:, 0]
            target = mocap + a[:, :3] * self.action_scale
            mocap.copy_(torch.maximum(torch.minimum(target, self._mocap_high), self._mocap_low))
            s.sim.ctrl[:, 0] = -a[:, 3]  # tendon force: positive opens the fingers; action +1 closes

    def _evaluate(self, action: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Reward and success of every world from the blocks' named state (refreshed after the physics). The
        ``"paper"`` version evaluates them with the original MTBench's ``tolerance`` (see
        :func:`~.reward_utils.mtbench_tolerance`)."""
        rewards, successes = [], []
        with mtbench_tolerance(self.reward_version == "paper"):
            for (task, s), dense_reward, success_reward, sl in zip(self.blocks, self._dense_rewards,
                                                                  self._success_rewards, self.slices):
                a = action[sl]
                scaled = dense_reward(s, a) * (task.dense_scale * self.reward_scale)
                success = task.success(s, a)
                rewards.append(torch.where(success, success_reward(s, a), scaled))
                successes.append(success)
        return torch.cat(rewards), torch.cat(successes)

    # ------------------------------------------------------------------ the step, as four torch stages
    # Each stage reads and writes only persistent buffers, so that on the GPU it can be replayed from a CUDA
    # graph (``GraphedStage``) between the Warp graph launches of the physics.
    def _stage_action(self) -> None:
        """Clamp the action to [-1, 1]; a NaN/inf component is replaced by 0 (and counted) before it can reach
        the physics."""
        finite = torch.isfinite(self._action_in)
        self._nonfinite_action.copy_(~finite.all(-1))
        self._action.copy_(torch.where(finite, self._action_in, torch.zeros_like(self._action_in)).clamp(-1.0, 1.0))
        self._apply_action(self._action)

    def _stage_evaluate(self) -> None:
        """After physics: observation, reward, success, statistics, which worlds are done; stage their reset."""
        self._refresh_kinematic_quantities()
        frame = self._frames()
        reward, success = self._evaluate(self._action)
        unhealthy = torch.empty_like(self._done)
        for sim, worlds in zip(self._sims, self._sim_worlds):  # each sim once, into the env's world order
            unhealthy[worlds] = sim.unhealthy()
        reward = torch.where(torch.isfinite(reward) & ~unhealthy, reward, torch.zeros_like(reward))
        self._step_count += 1
        self._ep_return += reward
        self._ep_success |= success & ~unhealthy
        done = (self._step_count >= self.max_episode_steps) | unhealthy
        self._accumulate_stats(done, unhealthy)
        self._frame.copy_(frame)
        self._reward.copy_(reward)
        self._done.copy_(done)
        self._stage_resets(self._done)

    def _stage_place_objects(self) -> None:
        self._place_objects(self._done)

    def _stage_finish(self) -> None:
        """After the reset kinematics: record reset states, build the returned observation, start episodes."""
        self._record_reset(self._done)
        reset_frame = self._frames()
        done = self._done[:, None]
        frame = torch.where(done, reset_frame, self._frame)
        # Meta-World: the previous frame of an episode's first observation is that frame itself
        self._obs.copy_(self._observation(frame, torch.where(done, reset_frame, self._prev_frame)))
        self._prev_frame.copy_(frame)
        self._begin_episode(self._done)

    # ------------------------------------------------------------------ EnvBase API
    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = checked_action(tensordict, self.batch_size[0], ACTION_DIM, "values in [-1, 1]")
        out = self._core_step(action)
        return TensorDict(
            {
                "observation": out["observation"],
                "task_id": self.task_id,
                "reward": out["reward"],
                "done": out["done"],
                "terminated": torch.zeros_like(out["done"]),
                "truncated": out["done"].clone(),
            },
            batch_size=self.batch_size,
            device=self.device,
        )

    def _core_step(self, action: torch.Tensor) -> dict[str, torch.Tensor]:
        """One control step of every world: action, physics of every block, observation, reward, statistics and
        autoreset of finished worlds (native autoreset). Branch-free tensor work, no host synchronisation; on
        the GPU the torch stages replay CUDA graphs between the blocks' physics graphs."""
        self._action_in.copy_(action)
        for _, part in self.step_parts:
            part()
        # the buffers are overwritten by the next step
        return {"observation": self._obs.clone(), "reward": self._reward[:, None].clone(),
                "done": self._done[:, None].clone()}

    def _accumulate_stats(self, done: torch.Tensor, unhealthy: torch.Tensor) -> None:
        counted = (done & self._ep_counted).float()
        rows = torch.stack([counted, counted * self._ep_success.float(), counted * self._ep_return,
                            counted * self._step_count.float(), unhealthy.float(), self._nonfinite_action.float()])
        self._stats.index_add_(1, self.task_id, rows)

    def _begin_episode(self, mask: torch.Tensor) -> None:
        self._step_count.masked_fill_(mask, 0)
        self._ep_return.masked_fill_(mask, 0.0)
        self._ep_success.masked_fill_(mask, False)
        self._ep_counted |= mask

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        n = self.batch_size[0]
        mask = reset_mask(tensordict, n, self.device)
        self._reset_worlds(mask)
        frame = self._frames()
        obs = self._observation(frame, torch.where(mask[:, None], frame, self._prev_frame))
        self._prev_frame.copy_(frame)
        self._begin_episode(mask)
        if self.random_start_progress:
            start = torch.randint(0, self.max_episode_steps, (n,), generator=self._generator, device=self.device)
            self._step_count.copy_(torch.where(mask, start, self._step_count))
            self._ep_counted &= ~(mask & (start > 0))
        return TensorDict(
            {
                "observation": obs,
                "task_id": self.task_id.clone(),
                "done": torch.zeros(n, 1, dtype=torch.bool, device=self.device),
                "terminated": torch.zeros(n, 1, dtype=torch.bool, device=self.device),
                "truncated": torch.zeros(n, 1, dtype=torch.bool, device=self.device),
            },
            batch_size=self.batch_size,
            device=self.device,
        )

    def _set_seed(self, seed: int | None) -> None:
        self._generator.manual_seed(0 if seed is None else int(seed))

    # ------------------------------------------------------------------ checkpointing
    _EPISODE_STATE = ("_step_count", "_ep_return", "_ep_success", "_ep_counted", "_prev_frame", "_vec_sampled",
                      "_stats")
    _TASK_STATE = ("goal", "obj_init_pos", "init_tcp", "init_left_pad", "init_right_pad")
    # reward_version is recorded with the state: resuming across versions is refused

    def get_extra_state(self) -> dict:
        """Everything needed to continue the exact same trajectories: episode bookkeeping, the reset sampler's
        RNG, per-task buffers and every block's physics state (included in ``env.state_dict()``)."""
        blocks = []
        for b, (task, s) in enumerate(self.blocks):
            block = {
                "task": {k: getattr(s, k).clone() for k in self._TASK_STATE},
                "buffers": {k: v.clone() for k, v in s.buffers.items()},
                "reset_vec": self._reset_vec[b].clone(),
            }
            if not self.group_models:
                block = {"sim": s.sim.get_state(), **block}
            blocks.append(block)
        state = {
            "task_names": list(self.task_names),
            "task_counts": list(self.task_counts),
            "reward_version": self.reward_version,
            "episode": {k: getattr(self, k).clone() for k in self._EPISODE_STATE},
            "generator": self._generator.get_state(),
            "blocks": blocks,
        }
        if self.group_models:  # one physics state per distinct sim
            state["model_groups"] = [list(g) for g in self.model_groups]
            state["sims"] = [sim.get_state() for sim in self._sims]
        return state

    def set_extra_state(self, state: dict) -> None:
        if state["task_names"] != list(self.task_names) or state["task_counts"] != list(self.task_counts):
            raise RuntimeError(
                f"env state is for tasks {state['task_names']} x {state['task_counts']}, this env has "
                f"{self.task_names} x {self.task_counts}"
            )
        saved_version = state.get("reward_version", "paper")
        if saved_version != self.reward_version:
            raise RuntimeError(f"env state was saved with reward_version={saved_version!r}, this env uses "
                               f"{self.reward_version!r}; a run cannot continue across reward versions")
        saved_groups = state.get("model_groups", [[i] for i in range(self.num_tasks)])
        if saved_groups != self.model_groups:
            raise RuntimeError(f"env state was saved with physics blocks {saved_groups} (group_models="
                               f"{'model_groups' in state}), this env has {self.model_groups} (group_models="
                               f"{self.group_models}); build the env with group_models={'model_groups' in state} "
                               f"(in a training config: env.overrides.group_models={str('model_groups' in state).lower()})")
        for k, v in state["episode"].items():
            getattr(self, k).copy_(v)
        if "sims" in state:
            for sim, saved in zip(self._sims, state["sims"]):
                sim.set_state(saved)
        self._generator.set_state(state["generator"].cpu() if self.device.type == "cpu" else state["generator"])
        for b, ((task, s), saved) in enumerate(zip(self.blocks, state["blocks"])):
            if "sim" in saved:
                s.sim.set_state(saved["sim"])
            for k, v in saved["task"].items():
                getattr(s, k).copy_(v)
            for k, v in saved["buffers"].items():
                s.buffers[k].copy_(v)
            self._reset_vec[b].copy_(saved["reset_vec"])
        self._refresh_kinematic_quantities()

    # ------------------------------------------------------------------ statistics
    STAT_KEYS = ("episodes", "success", "return", "length", "unhealthy", "nonfinite_actions")

    def exclude_episodes(self, mask: torch.Tensor) -> None:
        """Leave the current episodes of the worlds in ``mask`` ([N] bool) out of :meth:`pop_episode_stats` (their
        next episodes count again): an evaluation counting only the first episode of every world calls it after
        each step with the worlds that already finished one. No host synchronisation."""
        self._ep_counted &= ~mask.to(device=self.device, dtype=torch.bool).reshape(self._ep_counted.shape)

    def pop_episode_stats(self) -> TensorDict:
        """Per-task sums over the episodes finished since the last call (``[K]`` tensors, on the env device):
        ``episodes``, ``success`` (episodes with success at any step), ``return``, ``length``, ``unhealthy``
        (worlds reset because of NaN / runaway state / buffer overflow) and ``nonfinite_actions`` (steps whose
        action had a NaN/inf component, replaced by 0)."""
        stats = self._stats.clone()
        self._stats.zero_()
        return TensorDict(dict(zip(self.STAT_KEYS, stats.unbind(0))), batch_size=[self.num_tasks])
