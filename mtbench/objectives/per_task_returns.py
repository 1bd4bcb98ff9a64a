"""MT-GRPO advantages as a TorchRL value estimator: per-task standardised Monte-Carlo returns."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torchrl.objectives.value import ValueEstimatorBase

from .mt_utils import per_task_standardize
from .per_task_gae import rollout_time_dim, task_ids


def discounted_reward_to_go(reward: torch.Tensor, done: torch.Tensor, gamma: float, time_dim: int = 1) -> torch.Tensor:
    """``G_t = r_t + gamma * (1 - done_t) * G_{t+1}`` backwards over ``time_dim``, with ``G_T = 0``.

    ``done_t`` flags that the transition at ``t`` ended its episode (TorchRL's ``("next", "done")``), so the
    return does not leak across episodes. ``reward`` and ``done`` share a shape (e.g. ``[N, T, 1]``).
    """
    if reward.shape != done.shape:
        raise ValueError(f"reward {tuple(reward.shape)} and done {tuple(done.shape)} must have the same shape")
    r = reward.movedim(time_dim, 0)
    not_done = (~done.to(torch.bool)).to(r.dtype).movedim(time_dim, 0)
    out = torch.empty_like(r)
    running = torch.zeros_like(r[0])
    for t in range(r.shape[0] - 1, -1, -1):
        running = r[t] + gamma * not_done[t] * running
        out[t] = running
    return out.movedim(0, time_dim)


def grpo_advantages(
    reward: torch.Tensor,
    done: torch.Tensor,
    task_id: torch.Tensor,
    num_tasks: int,
    gamma: float = 0.99,
    eps: float = 1e-8,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Returns ``(advantage, G)`` for a ``[N, T, 1]`` window: ``G`` from :func:`discounted_reward_to_go`,
    ``advantage`` = ``G`` standardised per task over all ``(env, t)`` of the batch (unbiased std, +eps)."""
    returns = discounted_reward_to_go(reward, done, gamma, time_dim=1)
    return per_task_standardize(returns, task_id, num_tasks, eps=eps), returns


class PerTaskMCAdvantage(ValueEstimatorBase):
    """MT-GRPO's advantages (MTBench ``MTGRPOAgent``): no critic, Monte-Carlo returns, per-task standardisation.

    ``estimator(rollout)`` on a ``[*B, T]`` rollout (time last) writes ``returns`` = the discounted reward-to-go
    within the window (``G_t = r_t + gamma (1 - done_t) G_{t+1}``, ``G_T = 0``: no bootstrap) and ``advantage`` =
    the returns standardised per task ("group" = task) over the whole rollout (unbiased std, ``+ eps``).

    Args:
        gamma: discount (0.99).
        num_tasks: K.
        eps: added to the per-task standard deviation.
        device: unused (no buffers); accepted like every TorchRL estimator.
    """

    @dataclass
    class _AcceptedKeys:
        """The keys of :class:`ValueEstimatorBase` (repeated: TorchRL's ``set_keys`` accepts only a class's own
        fields) plus ``task_id`` (per-sample task index) and ``returns``
        (written)."""

        advantage: NestedKey = "advantage"
        value_target: NestedKey = "value_target"
        value: NestedKey = "state_value"
        reward: NestedKey = "reward"
        done: NestedKey = "done"
        terminated: NestedKey = "terminated"
        steps_to_next_obs: NestedKey = "steps_to_next_obs"
        sample_log_prob: NestedKey = "action_log_prob"
        task_id: NestedKey = "task_id"
        returns: NestedKey = "returns"

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys

    def __init__(
        self, *, gamma: float, num_tasks: int, eps: float = 1e-8, device: torch.device | str | None = None
    ) -> None:
        super().__init__(value_network=None, device=device)
        self.gamma = float(gamma)
        self.num_tasks = int(num_tasks)
        self.eps = float(eps)

    @property
    def in_keys(self) -> list[NestedKey]:
        k = self.tensor_keys
        return [("next", k.reward), ("next", k.done), k.task_id]

    @property
    def out_keys(self) -> list[NestedKey]:
        return [self.tensor_keys.advantage, self.tensor_keys.returns]

    @torch.no_grad()
    def forward(
        self,
        tensordict: TensorDictBase,
        *,
        params: TensorDictBase | None = None,
        target_params: TensorDictBase | None = None,
        time_dim: int | None = None,
    ) -> TensorDictBase:
        """Write ``advantage`` and ``returns`` into ``tensordict`` (returned); ``params``/``target_params`` are
        accepted for API compatibility (there is no value network)."""
        tdim = rollout_time_dim(self, tensordict, time_dim)
        keys = self.tensor_keys
        reward = tensordict.get(("next", keys.reward))
        done = tensordict.get(("next", keys.done))
        returns = discounted_reward_to_go(reward, done, self.gamma, time_dim=tdim)
        advantage = per_task_standardize(returns, task_ids(tensordict, keys.task_id), self.num_tasks, eps=self.eps)
        tensordict.set(keys.advantage, advantage)
        tensordict.set(keys.returns, returns)
        return tensordict


__all__ = ["PerTaskMCAdvantage", "discounted_reward_to_go", "grpo_advantages"]
