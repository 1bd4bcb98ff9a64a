"""MT-GRPO loss (MTBench ``MTGRPOAgent``): critic-free PPO with per-task standardised Monte-Carlo returns.

* returns: discounted reward-to-go *within the collected window* (horizon = episode length, 150 for
  Meta-World), ``G_t = r_t + gamma * (1 - done_t) * G_{t+1}``, ``G_T = 0`` (no bootstrap: there is no critic);
* advantages: the returns standardised per task ("group" = task) over the whole batch, once per iteration;
* loss: PPO clipped surrogate + entropy bonus + bounds loss; no KL penalty, no reference policy.

If the env's episode clocks are staggered (MTBench ``init_at_random_progress``) a window of one episode
length straddles two episodes, so the tail of the window gets truncated MC returns (as in MTBench).
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from tensordict.nn import ProbabilisticTensorDictSequential

from .mt_utils import per_task_standardize
from .ppo import MTClipPPOBase


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


class MTGRPOLoss(MTClipPPOBase):
    """Critic-free multi-task PPO with group (= task) standardised Monte-Carlo advantages.

    Args:
        actor_network: probabilistic actor (see :func:`mtbench.trainer.actor_critic.make_actor`).
        num_tasks: K.
        clip_epsilon: 0.2; entropy_coeff: 0.005; bounds_coeff: 1e-4 (soft bound 1.1); gamma: 0.99.
        reduction: ``"mean"``, ``"sum"`` or ``"none"`` (per-sample ``loss_objective``, ``loss_entropy``,
            ``loss_bounds``).
    """

    def __init__(
        self,
        actor_network: ProbabilisticTensorDictSequential,
        *,
        num_tasks: int,
        clip_epsilon: float = 0.2,
        entropy_coeff: float = 0.005,
        bounds_coeff: float = 1e-4,
        soft_bound: float = 1.1,
        gamma: float = 0.99,
        advantage_eps: float = 1e-8,
        reduction: str = "mean",
        task_id_key: str = "task_id",
    ) -> None:
        super().__init__(
            actor_network,
            None,
            num_tasks=num_tasks,
            clip_epsilon=clip_epsilon,
            entropy_coeff=entropy_coeff,
            critic_coeff=None,
            clip_value=None,
            bounds_coeff=bounds_coeff,
            soft_bound=soft_bound,
            per_task_advantage_norm=False,
            advantage_eps=advantage_eps,
            reduction=reduction,
            task_id_key=task_id_key,
        )
        self.gamma = float(gamma)

    @torch.no_grad()
    def compute_advantage(self, data: TensorDictBase) -> TensorDictBase:
        """Fill ``advantage`` (per-task standardised returns) and ``returns`` of a ``[N, T]`` rollout."""
        if data.batch_dims != 2:
            raise ValueError(f"compute_advantage expects a [num_envs, time] batch, got batch_size={data.batch_size}")
        td = data.clone(False)
        next_td = td.get("next")
        reward = next_td.get(self.tensor_keys.reward)
        done = next_td.get(self.tensor_keys.done)
        advantage, returns = grpo_advantages(
            reward, done, self._task_ids(td), self.num_tasks, gamma=self.gamma, eps=self.advantage_eps
        )
        td.set(self.tensor_keys.advantage, advantage)
        td.set("returns", returns)
        return td
