"""A small pure-torch multi-task env that follows the mtbench env contract (docs/design.md).

Used by the trainer/loss tests so that they never depend on the physics env. Each task is a point mass in
``action_dim`` dimensions that must reach a random goal; tasks differ by their action map (a signed
permutation, so the policy has to read the one-hot), their reward scale and their success radius.
Episodes end by truncation only (``max_episode_steps``), the env resets done rows inside ``_step``
(TorchRL native autoreset) and accumulates per-task episode statistics on the device.
"""

from __future__ import annotations

from typing import Any, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase


class SyntheticMTEnv(EnvBase):
    """Multi-task reach-a-goal env with the mtbench key contract.

    Observation = ``[pos (A), goal (A), progress (1)]`` (S = 2A + 1) followed by the one-hot task id (K).
    Reward of task k = ``reward_scales[k] * (1 - |pos - goal|)``; success when ``|pos - goal| < success_radius[k]``.

    Args:
        task_counts: number of envs per task (contiguous blocks), e.g. ``[4, 4, 4]``.
        action_dim: A.
        max_episode_steps: episode length (truncation).
        reward_scales: per-task reward scale (default ``1, 10, 100, ...`` cycling) to exercise per-task
            value normalisation.
        success_radius: per-task success radius (default 0.25).
        random_initial_progress: desynchronise the episode clocks at the first reset (as MTBench does).
        terminate_on_success: end an episode (terminated) at its first success step.
        nan_reward_at_step: if set, the reward of env 0 is NaN at that (0-based) step count of the env —
            a stand-in for a physics blow-up.
        device: torch device.
        seed: seed of the env's private generator.
    """

    def __init__(
        self,
        task_counts: Sequence[int] = (4, 4, 4),
        *,
        action_dim: int = 2,
        max_episode_steps: int = 16,
        reward_scales: Sequence[float] | None = None,
        success_radius: Sequence[float] | float = 0.25,
        random_initial_progress: bool = True,
        nan_reward_at_step: int | None = None,
        terminate_on_success: bool = False,
        task_names: Sequence[str] | None = None,
        device: torch.device | str = "cpu",
        seed: int = 0,
    ) -> None:
        task_counts = [int(c) for c in task_counts]
        n = sum(task_counts)
        k = len(task_counts)
        super().__init__(device=device, batch_size=torch.Size([n]))
        self._torchrl_native_autoreset = True
        self.num_tasks = k
        self.task_counts = task_counts
        self.task_names = list(task_names) if task_names is not None else [f"task{i}" for i in range(k)]
        if len(self.task_names) != k:
            raise ValueError(f"{len(self.task_names)} task names for {k} tasks")
        self.action_dim = int(action_dim)
        self.state_dim = 2 * self.action_dim + 1
        self.max_episode_steps = int(max_episode_steps)
        self.random_initial_progress = random_initial_progress
        self.nan_reward_at_step = nan_reward_at_step
        self.terminate_on_success = bool(terminate_on_success)
        dev = self.device
        if reward_scales is None:
            reward_scales = [10.0 ** (i % 3) for i in range(k)]
        if isinstance(success_radius, (int, float)):
            success_radius = [float(success_radius)] * k
        self.register_buffer("reward_scales", torch.tensor(list(reward_scales), dtype=torch.float32, device=dev))
        self.register_buffer("success_radius", torch.tensor(list(success_radius), dtype=torch.float32, device=dev))
        self.register_buffer(
            "task_id",
            torch.repeat_interleave(torch.arange(k, device=dev), torch.tensor(task_counts, device=dev)),
        )
        # action map of each task: a signed permutation (fixed, derived from the task index)
        maps = []
        for i in range(k):
            perm = torch.roll(torch.arange(self.action_dim), i)
            sign = torch.tensor([1.0 if ((i >> j) & 1) == 0 else -1.0 for j in range(self.action_dim)])
            maps.append(torch.eye(self.action_dim)[perm] * sign.unsqueeze(-1))
        self.register_buffer("action_maps", torch.stack(maps).to(dev))
        self.register_buffer("one_hot", torch.eye(k, device=dev)[self.task_id])
        # dynamic state
        self.register_buffer("pos", torch.zeros(n, self.action_dim, device=dev))
        self.register_buffer("goal", torch.zeros(n, self.action_dim, device=dev))
        self.register_buffer("steps", torch.zeros(n, dtype=torch.long, device=dev))
        self.register_buffer("ep_return", torch.zeros(n, device=dev))
        self.register_buffer("ep_success", torch.zeros(n, dtype=torch.bool, device=dev))
        self.register_buffer("ep_counted", torch.ones(n, dtype=torch.bool, device=dev))
        self.register_buffer("global_step", torch.zeros((), dtype=torch.long, device=dev))
        self.register_buffer("acc", torch.zeros(4, k, device=dev))  # episodes, success, return, length
        self.rng = torch.Generator(device=dev)
        self.rng.manual_seed(seed)

        obs_dim = self.state_dim + k
        self.observation_spec = Composite(
            observation=Unbounded((n, obs_dim), device=dev),
            task_id=Categorical(k, shape=(n,), dtype=torch.int64, device=dev),
            shape=(n,),
            device=dev,
        )
        self.action_spec = Bounded(-1.0, 1.0, shape=(n, self.action_dim), device=dev)
        self.reward_spec = Unbounded((n, 1), device=dev)
        d = Categorical(2, shape=(n, 1), dtype=torch.bool, device=dev)
        self.full_done_spec = Composite(done=d.clone(), terminated=d.clone(), truncated=d.clone(), shape=(n,), device=dev)

    # ------------------------------------------------------------------ helpers
    def _uniform(self, *shape: int) -> torch.Tensor:
        return torch.rand(*shape, generator=self.rng, device=self.device) * 2.0 - 1.0

    def _obs(self) -> torch.Tensor:
        progress = (self.steps.float() / self.max_episode_steps).unsqueeze(-1)
        return torch.cat([self.pos, self.goal, progress, self.one_hot], dim=-1)

    def _reset_rows(self, mask: torch.Tensor, random_progress: bool = False) -> None:
        n = self.batch_size[0]
        m = mask.unsqueeze(-1)
        self.pos.copy_(torch.where(m, self._uniform(n, self.action_dim), self.pos))
        self.goal.copy_(torch.where(m, self._uniform(n, self.action_dim), self.goal))
        if random_progress:
            start = torch.randint(0, self.max_episode_steps, (n,), generator=self.rng, device=self.device)
        else:
            start = torch.zeros_like(self.steps)
        self.steps.copy_(torch.where(mask, start, self.steps))
        self.ep_return.masked_fill_(mask, 0.0)
        self.ep_success.masked_fill_(mask, False)
        self.ep_counted |= mask

    # ------------------------------------------------------------------ EnvBase API
    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        n = self.batch_size[0]
        reset = None if tensordict is None else tensordict.get("_reset", None)
        if reset is None:
            mask = torch.ones(n, dtype=torch.bool, device=self.device)
            self._reset_rows(mask, random_progress=self.random_initial_progress)
        else:
            self._reset_rows(reset.reshape(n).to(torch.bool))
        z = torch.zeros(n, 1, dtype=torch.bool, device=self.device)
        return TensorDict(
            {"observation": self._obs(), "task_id": self.task_id.clone(), "done": z, "terminated": z.clone(), "truncated": z.clone()},
            batch_size=self.batch_size,
            device=self.device,
        )

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = tensordict.get("action").clamp(-1.0, 1.0)
        move = torch.einsum("nij,nj->ni", self.action_maps[self.task_id], action)
        self.pos.copy_((self.pos + 0.25 * move).clamp(-2.0, 2.0))
        dist = (self.pos - self.goal).norm(dim=-1)
        reward = self.reward_scales[self.task_id] * (1.0 - dist)
        if self.nan_reward_at_step is not None:
            hit = self.global_step == self.nan_reward_at_step
            reward = reward.clone()
            reward[0] = torch.where(hit, torch.full_like(reward[0], float("nan")), reward[0])
        success = dist < self.success_radius[self.task_id]
        self.steps.add_(1)
        self.global_step.add_(1)
        self.ep_return.add_(reward)
        self.ep_success.logical_or_(success)
        terminated = success & self.terminate_on_success
        truncated = (self.steps >= self.max_episode_steps) & ~terminated
        ended = terminated | truncated
        # per-task statistics of the counted episodes that end now (no host sync)
        fin = (ended & self.ep_counted).float()
        self.acc[0].index_add_(0, self.task_id, fin)
        self.acc[1].index_add_(0, self.task_id, fin * self.ep_success.float())
        self.acc[2].index_add_(0, self.task_id, fin * self.ep_return)
        self.acc[3].index_add_(0, self.task_id, fin * self.steps.float())
        self._reset_rows(ended)
        return TensorDict(
            {
                "observation": self._obs(),
                "task_id": self.task_id.clone(),
                "reward": reward.unsqueeze(-1),
                "done": ended.unsqueeze(-1),
                "terminated": terminated.unsqueeze(-1),
                "truncated": truncated.unsqueeze(-1),
            },
            batch_size=self.batch_size,
            device=self.device,
        )

    def _set_seed(self, seed: int | None) -> None:
        if seed is not None:
            self.rng.manual_seed(seed)

    def exclude_episodes(self, mask: torch.Tensor) -> None:
        """Leave the current episodes of ``mask``'s worlds out of the statistics (mtbench env contract)."""
        self.ep_counted &= ~mask.reshape(-1)

    def pop_episode_stats(self) -> TensorDict:
        """Per-task sums since the last call: ``episodes``, ``success``, ``return``, ``length`` ([K] each)."""
        acc = self.acc.clone()
        self.acc.zero_()
        return TensorDict(
            {"episodes": acc[0], "success": acc[1], "return": acc[2], "length": acc[3]},
            batch_size=[self.num_tasks],
            device=self.device,
        )

    def get_extra_state(self) -> dict[str, Any]:
        return {"rng": self.rng.get_state()}

    def set_extra_state(self, state: dict[str, Any]) -> None:
        self.rng.set_state(state["rng"])


def make_synthetic_env(num_tasks: int = 3, envs_per_task: int = 4, **kwargs: Any) -> SyntheticMTEnv:
    """Convenience constructor: ``num_tasks`` tasks with ``envs_per_task`` envs each."""
    return SyntheticMTEnv([envs_per_task] * num_tasks, **kwargs)
