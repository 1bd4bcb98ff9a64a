"""MT-GRPO loss (MTBench ``MTGRPOAgent``): critic-free PPO with per-task standardised Monte-Carlo returns.

* returns: discounted reward-to-go *within the collected window* (horizon = episode length, 150 for
  Meta-World), ``G_t = r_t + gamma * (1 - done_t) * G_{t+1}``, ``G_T = 0`` (no bootstrap: there is no critic);
* advantages: the returns standardised per task ("group" = task) over the whole batch, once per iteration --
  the loss's default value estimator :class:`~mtbench.objectives.per_task_returns.PerTaskMCAdvantage`;
* loss: PPO clipped surrogate + entropy bonus + bounds loss; no KL penalty, no reference policy.

If the env's episode clocks are staggered (MTBench ``init_at_random_progress``) a window of one episode
length straddles two episodes, so the tail of the window gets truncated MC returns (as in MTBench).
"""

from __future__ import annotations

from typing import Any

from tensordict.nn import ProbabilisticTensorDictSequential

from .per_task_returns import PerTaskMCAdvantage, discounted_reward_to_go, grpo_advantages
from .ppo import MTClipPPOBase


class MTGRPOLoss(MTClipPPOBase):
    """Critic-free multi-task PPO with group (= task) standardised Monte-Carlo advantages.

    ``loss.value_estimator(rollout)`` (:class:`~mtbench.objectives.per_task_returns.PerTaskMCAdvantage`) writes
    the advantages of a ``[N, T]`` rollout; minibatches of it then go through ``loss(minibatch)`` (no per-minibatch
    re-standardisation).

    Args:
        actor_network: probabilistic actor (see :func:`mtbench.trainer.actor_critic.make_actor`).
        num_tasks: K.
        clip_epsilon: 0.2; entropy_coeff: 0.005; bounds_coeff: 1e-4 (soft bound 1.1); gamma: 0.99.
        advantage_eps: added to the per-task standard deviation of the returns.
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
        )
        self.gamma = float(gamma)
        self.make_value_estimator()

    def _default_estimator(self, **hyperparams: Any) -> PerTaskMCAdvantage:
        kwargs: dict[str, Any] = dict(gamma=self.gamma, num_tasks=self.num_tasks, eps=self.advantage_eps)
        kwargs.update(hyperparams)
        return PerTaskMCAdvantage(**kwargs)


__all__ = ["MTGRPOLoss", "discounted_reward_to_go", "grpo_advantages"]
