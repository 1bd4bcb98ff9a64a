"""MT-PPO loss (MTBench / rl_games conventions) on top of TorchRL's ``ClipPPOLoss``.

Conventions reproduced from MTBench's ``MTA2CAgent`` (see docs/training.md):

* advantages, value targets and old values come from the loss's value estimator, by default
  :class:`~mtbench.objectives.per_task_gae.PerTaskGAE` (per-task value normalisation: the critic predicts
  *normalised* values; GAE(0.99, 0.95) on de-normalised values with the truncation bootstrap of
  ``GAE(auto_reset_env=True)``; the returns update the per-task statistics);
* advantages standardised per task inside every minibatch (``actor_loss_mt``);
* clipped surrogate (0.2), clipped value loss ``max((V-R)^2, (V_old + clip(V-V_old, ±0.2) - R)^2)``
  weighted by ``0.5 * critic_coef`` (critic_coef = 4), entropy bonus 0.005, bounds loss 1e-4 on the action
  mean (soft bound 1.1).

Use it like any TorchRL loss: ``loss.value_estimator(rollout)`` on the collected ``[N, T]`` rollout (no
gradients), then ``loss(minibatch)`` on flat minibatches of it. ``reduction="none"`` returns per-sample
``loss_objective``, ``loss_critic``, ``loss_entropy`` and ``loss_bounds`` (shape = batch shape) for the
gradient-manipulation wrappers; their mean over the batch is the ``reduction="mean"`` output, so summing the
``loss_*`` entries gives rl_games' total loss.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import ProbabilisticTensorDictSequential, TensorDictModule
from tensordict.utils import NestedKey
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import ValueEstimatorBase

from .mt_utils import bounds_loss, gaussian_policy_kl, per_task_standardize
from .per_task_gae import PerTaskGAE

_VALID_REDUCTIONS = ("mean", "sum", "none")


class MTClipPPOBase(ClipPPOLoss):
    """Shared forward of :class:`MTPPOLoss` and :class:`~mtbench.objectives.grpo.MTGRPOLoss`.

    Expects the minibatch to contain ``advantage`` (and, with a critic, ``value_target`` and the old normalised
    ``state_value``): run ``loss.value_estimator(rollout)`` on the collected ``[N, T]`` rollout first.
    Output keys: ``loss_objective``, ``loss_entropy``, ``loss_bounds`` (+ ``loss_critic``), and detached
    metrics ``entropy``, ``clip_fraction``, ``kl_approx``, ``kl`` (rl_games' analytic Gaussian KL, used by
    the adaptive learning rate), ``ratio_mean`` (+ ``value_clip_fraction``, ``explained_variance``).

    Every key the loss or its value estimator reads is declared in :class:`_AcceptedKeys` and can be renamed
    with ``loss.set_keys(...)``; the estimator's keys follow.
    """

    @dataclass
    class _AcceptedKeys(ClipPPOLoss._AcceptedKeys):
        """Keys of ``ClipPPOLoss`` (``advantage``, ``value_target``, ``value``, ``sample_log_prob``, ``action``,
        ``reward``, ``done``, ``terminated``) plus:

        Attributes:
            truncated: ``("next", truncated)`` drives the truncation bootstrap of the value estimator.
            task_id: per-sample task index (int64, batch-shaped, optional trailing 1).
            loc, scale: the behaviour policy's Gaussian parameters written by the actor during collection
                (analytic KL metric).
            returns: un-normalised returns written by the value estimator.
        """

        truncated: NestedKey = "truncated"
        task_id: NestedKey = "task_id"
        loc: NestedKey = "loc"
        scale: NestedKey = "scale"
        returns: NestedKey = "returns"

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys

    def __init__(
        self,
        actor_network: ProbabilisticTensorDictSequential,
        critic_network: TensorDictModule | None,
        *,
        num_tasks: int,
        clip_epsilon: float = 0.2,
        entropy_coeff: float = 0.005,
        critic_coeff: float | None = None,
        clip_value: float | None = None,
        bounds_coeff: float = 1e-4,
        soft_bound: float = 1.1,
        per_task_advantage_norm: bool = True,
        advantage_eps: float = 1e-8,
        reduction: str = "mean",
    ) -> None:
        if reduction not in _VALID_REDUCTIONS:
            raise ValueError(f"unknown reduction {reduction!r}; valid choices: {list(_VALID_REDUCTIONS)}")
        if num_tasks < 1:
            raise ValueError(f"num_tasks must be >= 1, got {num_tasks}")
        super().__init__(
            actor_network,
            critic_network,
            clip_epsilon=clip_epsilon,
            entropy_bonus=True,
            entropy_coeff=entropy_coeff,
            critic_coeff=critic_coeff,
            loss_critic_type="l2",
            normalize_advantage=False,
            clip_value=clip_value,
            reduction=reduction,
        )
        self.num_tasks = int(num_tasks)
        self._clip_value_f = None if clip_value is None else float(clip_value)
        self.register_buffer("bounds_coeff", torch.tensor(float(bounds_coeff)))
        self.soft_bound = float(soft_bound)
        self.per_task_advantage_norm = per_task_advantage_norm
        self.advantage_eps = float(advantage_eps)

    # ------------------------------------------------------------------ keys and value estimator
    def _set_in_keys(self) -> None:
        """The entries :meth:`forward` reads (the value estimator's are its own ``in_keys``)."""
        k = self.tensor_keys
        keys: list[NestedKey] = [*self.actor_network.in_keys, k.task_id, k.action, k.sample_log_prob, k.advantage]
        keys += [k.loc, k.scale]
        if self._has_critic:
            keys += [*self.critic_network.in_keys, k.value_target, k.value]
        self._in_keys = list(dict.fromkeys(keys))

    def _forward_value_estimator_keys(self, **kwargs: Any) -> None:
        """Give the value estimator every key it declares under the same name (task id, truncated, ...)."""
        estimator = getattr(self, "_value_estimator", None)
        if estimator is not None:
            names = estimator._AcceptedKeys.__dataclass_fields__
            keys = {n: getattr(self.tensor_keys, n) for n in names if hasattr(self.tensor_keys, n)}
            out_keys = getattr(getattr(estimator, "value_network", None), "out_keys", None)
            if out_keys is not None and keys.get("value") not in out_keys:
                keys.pop("value", None)  # a critic writing elsewhere: set_keys(value=...) forwards it later
            estimator.set_keys(**keys)
        self._set_in_keys()

    def _default_estimator(self, **hyperparams: Any) -> ValueEstimatorBase:  # pragma: no cover - abstract
        raise NotImplementedError

    def make_value_estimator(self, value_type: Any = None, **hyperparams: Any) -> MTClipPPOBase:
        """``None``: the loss's own multi-task estimator (``hyperparams`` override its defaults); otherwise as
        ``ClipPPOLoss`` (a ``ValueEstimators`` member, a ``ValueEstimatorBase`` subclass or instance). The loss's
        keys are forwarded to the new estimator."""
        if value_type is None:
            estimator = self._default_estimator(**hyperparams)
            self._value_estimator = estimator
            self.value_type = type(estimator)
        else:
            super().make_value_estimator(value_type, **hyperparams)
        self._forward_value_estimator_keys()
        return self

    def _task_ids(self, td: TensorDictBase) -> torch.Tensor:
        task_id = td.get(self.tensor_keys.task_id, None)
        if task_id is None:
            raise KeyError(f"{type(self).__name__}: task index {self.tensor_keys.task_id!r} missing from the batch")
        return task_id.reshape(td.batch_size)

    # ------------------------------------------------------------------ loss
    def _critic_loss(self, td: TensorDictBase) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """rl_games ``critic_loss`` times ``critic_coeff``: ``(V - R)^2``, or with value clipping
        ``max((V - R)^2, (V_old + clip(V - V_old, -c, c) - R)^2)``; per sample ``[*B, 1]``.

        Re-implemented (instead of ``PPOLoss.loss_critic``) so that no tensor is used in a Python ``if``
        (no host sync, no graph break under ``torch.compile``).
        """
        target = td.get(self.tensor_keys.value_target, None)
        if target is None:
            raise KeyError(
                f"'{self.tensor_keys.value_target}' missing; run loss.value_estimator(rollout) on the collected "
                "[N, T] rollout first"
            )
        with self.critic_network_params.to_module(self.critic_network, preserve_module_state=False):
            value = self.critic_network(td.select(*self.critic_network.in_keys)).get(self.tensor_keys.value)
        loss = (value - target) ** 2
        metrics: dict[str, torch.Tensor] = {}
        if self._clip_value_f is not None:
            old = td.get(self.tensor_keys.value, None)
            if old is None:
                raise KeyError(f"value clipping needs the old '{self.tensor_keys.value}' in the batch")
            delta = value - old
            clipped = old + delta.clamp(-self._clip_value_f, self._clip_value_f)
            loss = torch.maximum(loss, (clipped - target) ** 2)
            with torch.no_grad():
                metrics["value_clip_fraction"] = (delta.abs() > self._clip_value_f).float().mean()
        with torch.no_grad():
            resid = (target - value).var(correction=0)
            total = target.var(correction=0)
            metrics["explained_variance"] = 1.0 - resid / (total + torch.finfo(total.dtype).eps)
        return self.critic_coeff * loss, metrics

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        td = tensordict.clone(False)
        keys = self.tensor_keys
        advantage = td.get(keys.advantage, None)
        if advantage is None:
            raise KeyError(
                f"{type(self).__name__}: '{keys.advantage}' missing; run loss.value_estimator(rollout) on the "
                "collected [N, T] rollout first"
            )
        if advantage.ndim == td.batch_dims:
            advantage = advantage.unsqueeze(-1)
        task_id = self._task_ids(td)
        # behaviour-policy parameters, read before the actor re-writes loc/scale into ``td``
        old_loc = td.get(keys.loc, None)
        old_scale = td.get(keys.scale, None)
        if self.per_task_advantage_norm:
            advantage = per_task_standardize(advantage, task_id, self.num_tasks, eps=self.advantage_eps)

        log_weight, dist, kl_approx, log_is_weight = self._log_weight(td, adv_shape=advantage.shape[:-1])
        if log_is_weight is not None:  # only with delay_actor / max_importance_ratio (not used here)
            raise RuntimeError(f"{type(self).__name__} does not support delay_actor / max_importance_ratio")
        ratio = log_weight.exp()
        gain1 = ratio * advantage
        log_weight_clip = log_weight.clamp(*self._clip_bounds)
        gain2 = log_weight_clip.exp() * advantage
        loss_objective = -torch.minimum(gain1, gain2)

        entropy = dist.entropy()
        if entropy.shape == advantage.shape[:-1]:
            entropy = entropy.unsqueeze(-1)
        mu = dist.mean
        out: dict[str, torch.Tensor] = {
            "loss_objective": loss_objective,
            "loss_entropy": -self.entropy_coeff * entropy,
            "loss_bounds": self.bounds_coeff * bounds_loss(mu, self.soft_bound),
        }
        metrics: dict[str, torch.Tensor] = {}
        if self._has_critic:
            loss_critic, value_metrics = self._critic_loss(td)
            out["loss_critic"] = loss_critic
            metrics.update(value_metrics)
        with torch.no_grad():
            metrics["entropy"] = entropy.mean()
            metrics["clip_fraction"] = (log_weight_clip != log_weight).float().mean()
            metrics["kl_approx"] = kl_approx.mean()
            metrics["ratio_mean"] = ratio.mean()
            if old_loc is not None and old_scale is not None:
                metrics["kl"] = gaussian_policy_kl(mu, dist.stddev, old_loc, old_scale)
            else:
                metrics["kl"] = kl_approx.mean()
        result = TensorDict(
            {name: self._reduce_loss(value, td).squeeze(-1) for name, value in out.items()},
            batch_size=[],
        )
        for name, value in metrics.items():
            result.set(name, value.detach())
        self._clear_weakrefs(td, "actor_network_params", "critic_network_params")
        return result


class MTPPOLoss(MTClipPPOBase):
    """Multi-task clipped PPO with per-task value normalisation and per-task minibatch advantage norm.

    The default value estimator is :class:`~mtbench.objectives.per_task_gae.PerTaskGAE` (it holds the per-task
    value statistics: ``loss.value_estimator.value_norm``); ``loss.make_value_estimator(...)`` replaces it.

    Args:
        actor_network: probabilistic actor (``observation``, ``task_id`` -> ``loc``, ``scale``, ``action``,
            ``action_log_prob``); see :func:`mtbench.trainer.actor_critic.make_actor`.
        critic_network: value module writing the *normalised* ``state_value``.
        num_tasks: K.
        clip_epsilon: PPO ratio clip (0.2).
        entropy_coeff: entropy bonus weight (0.005).
        critic_coef: rl_games ``critic_coef`` (4); the critic loss is weighted by ``0.5 * critic_coef``.
        clip_value: value-clip radius in normalised units (0.2); ``None`` disables clipping.
        bounds_coeff: weight of the bounds loss on the action mean (1e-4); ``soft_bound`` 1.1.
        gamma, lmbda: GAE parameters of the default estimator (0.99, 0.95).
        normalize_value: per-task value normalisation in the default estimator (MTBench: True).
        value_norm_clip: clamp of normalised values (rl_games ``RunningMeanStd``: 5); ``None`` disables.
        value_norm_eps: variance epsilon of the value statistics (rl_games: 1e-5).
        per_task_advantage_norm: standardise advantages per task inside each minibatch (MTBench: True).
        reduction: ``"mean"`` (default), ``"sum"`` or ``"none"`` (per-sample ``loss_*``).
    """

    def __init__(
        self,
        actor_network: ProbabilisticTensorDictSequential,
        critic_network: TensorDictModule,
        *,
        num_tasks: int,
        clip_epsilon: float = 0.2,
        entropy_coeff: float = 0.005,
        critic_coef: float = 4.0,
        clip_value: float | None = 0.2,
        bounds_coeff: float = 1e-4,
        soft_bound: float = 1.1,
        gamma: float = 0.99,
        lmbda: float = 0.95,
        normalize_value: bool = True,
        value_norm_clip: float | None = 5.0,
        value_norm_eps: float = 1e-5,
        per_task_advantage_norm: bool = True,
        reduction: str = "mean",
    ) -> None:
        if critic_network is None:
            raise ValueError("MTPPOLoss needs a critic network (use MTGRPOLoss for the critic-free variant)")
        if critic_coef <= 0:
            raise ValueError(f"critic_coef must be > 0, got {critic_coef}")
        super().__init__(
            actor_network,
            critic_network,
            num_tasks=num_tasks,
            clip_epsilon=clip_epsilon,
            entropy_coeff=entropy_coeff,
            critic_coeff=0.5 * critic_coef,
            clip_value=clip_value,
            bounds_coeff=bounds_coeff,
            soft_bound=soft_bound,
            per_task_advantage_norm=per_task_advantage_norm,
            reduction=reduction,
        )
        self.critic_coef = float(critic_coef)
        self.gamma = float(gamma)
        self.lmbda = float(lmbda)
        self._estimator_defaults: dict[str, Any] = dict(
            normalize_value=normalize_value, value_norm_clip=value_norm_clip, value_norm_eps=value_norm_eps
        )
        self.make_value_estimator()

    def _default_estimator(self, **hyperparams: Any) -> PerTaskGAE:
        kwargs: dict[str, Any] = dict(
            gamma=self.gamma, lmbda=self.lmbda, num_tasks=self.num_tasks, **self._estimator_defaults
        )
        kwargs.update(hyperparams)
        device = self._default_device
        return PerTaskGAE(value_network=self.critic_network, device=device, **kwargs)
