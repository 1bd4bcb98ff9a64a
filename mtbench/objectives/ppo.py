"""MT-PPO loss (MTBench / rl_games conventions) on top of TorchRL's ``ClipPPOLoss``.

Conventions reproduced from MTBench's ``MTA2CAgent`` (see docs/training.md):

* per-task value normalisation: the critic predicts *normalised* values; GAE runs on values de-normalised
  with the per-task running statistics; the returns (value targets) update those statistics and both the
  old values and the targets are then normalised per task (rl_games clamps normalised values to ±5);
* GAE(gamma=0.99, lambda=0.95) with truncation bootstrap (``GAE(auto_reset_env=True)``: a truncated step
  gets ``r += gamma * V(s_t)``, since the native-autoreset env does not keep the terminal observation);
* advantages standardised per task inside every minibatch (``actor_loss_mt``);
* clipped surrogate (0.2), clipped value loss ``max((V-R)^2, (V_old + clip(V-V_old, ±0.2) - R)^2)``
  weighted by ``0.5 * critic_coef`` (critic_coef = 4), entropy bonus 0.005, bounds loss 1e-4 on the action
  mean (soft bound 1.1).

``reduction="none"`` returns per-sample ``loss_objective``, ``loss_critic``, ``loss_entropy`` and
``loss_bounds`` (shape = batch shape) for the gradient-manipulation wrappers; their mean over the batch is
the ``reduction="mean"`` output, so summing the ``loss_*`` entries gives rl_games' total loss.
"""

from __future__ import annotations

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import ProbabilisticTensorDictSequential, TensorDictModule
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE

from ..transforms.running_mean_std import PerTaskRunningMeanStd
from .mt_utils import bounds_loss, gaussian_policy_kl, per_task_standardize

_VALID_REDUCTIONS = ("mean", "sum", "none")


class MTClipPPOBase(ClipPPOLoss):
    """Shared forward of :class:`MTPPOLoss` and :class:`~mtbench.objectives.grpo.MTGRPOLoss`.

    Expects the batch to already contain ``advantage`` (and, with a critic, ``value_target`` and the old
    normalised ``state_value``): call :meth:`compute_advantage` on the collected ``[N, T]`` batch first.
    Output keys: ``loss_objective``, ``loss_entropy``, ``loss_bounds`` (+ ``loss_critic``), and detached
    metrics ``entropy``, ``clip_fraction``, ``kl_approx``, ``kl`` (rl_games' analytic Gaussian KL, used by
    the adaptive learning rate), ``ratio_mean`` (+ ``value_clip_fraction``, ``explained_variance``).
    """

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
        task_id_key: str = "task_id",
        loc_key: str = "loc",
        scale_key: str = "scale",
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
        self.task_id_key = task_id_key
        self.loc_key = loc_key
        self.scale_key = scale_key

    # ------------------------------------------------------------------ helpers
    @property
    def batch_keys(self) -> list[str]:
        """Entries of the prepared batch that :meth:`forward` reads (the trainer keeps only these)."""
        keys = list(dict.fromkeys([*self.actor_network.in_keys, self.task_id_key]))
        keys += [self.tensor_keys.action, self.tensor_keys.sample_log_prob, self.tensor_keys.advantage]
        keys += [self.loc_key, self.scale_key]
        if self._has_critic:
            keys += [*self.critic_network.in_keys, self.tensor_keys.value_target, self.tensor_keys.value]
        return list(dict.fromkeys(k for k in keys if isinstance(k, str)))

    def _task_ids(self, td: TensorDictBase) -> torch.Tensor:
        task_id = td.get(self.task_id_key, None)
        if task_id is None:
            raise KeyError(f"{type(self).__name__}: '{self.task_id_key}' missing from the batch")
        return task_id.reshape(td.batch_size)

    def compute_advantage(self, data: TensorDictBase) -> TensorDictBase:  # pragma: no cover - abstract
        raise NotImplementedError

    # ------------------------------------------------------------------ loss
    def _critic_loss(self, td: TensorDictBase) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """rl_games ``critic_loss`` times ``critic_coeff``: ``(V - R)^2``, or with value clipping
        ``max((V - R)^2, (V_old + clip(V - V_old, -c, c) - R)^2)``; per sample ``[*B, 1]``.

        Re-implemented (instead of ``PPOLoss.loss_critic``) so that no tensor is used in a Python ``if``
        (no host sync, no graph break under ``torch.compile``).
        """
        target = td.get(self.tensor_keys.value_target, None)
        if target is None:
            raise KeyError(f"'{self.tensor_keys.value_target}' missing; call loss.compute_advantage(rollout) first")
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
        advantage = td.get(self.tensor_keys.advantage, None)
        if advantage is None:
            raise KeyError(
                f"{type(self).__name__}: '{self.tensor_keys.advantage}' missing; call "
                "loss.compute_advantage(rollout) on the collected batch first"
            )
        if advantage.ndim == td.batch_dims:
            advantage = advantage.unsqueeze(-1)
        task_id = self._task_ids(td)
        # behaviour-policy parameters, read before the actor re-writes loc/scale into ``td``
        old_loc = td.get(self.loc_key, None)
        old_scale = td.get(self.scale_key, None)
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
        gamma, lmbda: GAE parameters (0.99, 0.95).
        normalize_value: per-task value normalisation (MTBench: True).
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
        task_id_key: str = "task_id",
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
            task_id_key=task_id_key,
        )
        self.critic_coef = float(critic_coef)
        self.value_norm: PerTaskRunningMeanStd | None = (
            PerTaskRunningMeanStd(num_tasks, 1, eps=value_norm_eps, clip=value_norm_clip) if normalize_value else None
        )
        self.make_value_estimator(GAE(gamma=gamma, lmbda=lmbda, value_network=None, auto_reset_env=True))

    @torch.no_grad()
    def _critic_values(self, observation_td: TensorDictBase) -> torch.Tensor:
        with self.critic_network_params.to_module(self.critic_network, preserve_module_state=False):
            out = self.critic_network(observation_td)
        return out.get(self.tensor_keys.value)

    def denormalize_values(self, values: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        """Map critic outputs (normalised) to the return scale of each task."""
        return values if self.value_norm is None else self.value_norm.denormalize(values, task_id)

    @torch.no_grad()
    def compute_advantage(self, data: TensorDictBase) -> TensorDictBase:
        """Fill ``advantage``, ``value_target`` and ``state_value`` of a collected ``[N, T]`` rollout.

        1. critic values of ``observation[:, t]`` for all t and of the last ``("next", "observation")``
           (rows that are done at the last step use a zero observation: their next value is masked);
           ``V(s_{t+1}) = V(observation[:, t+1])`` is valid for every non-done step;
        2. values de-normalised per task (current statistics) -> GAE with truncation bootstrap;
        3. per-task value statistics updated with the returns; ``state_value`` (old values, for value
           clipping) and ``value_target`` are stored normalised with the updated statistics.

        Returns a shallow copy of ``data`` with the new entries (``data`` itself is not modified).
        """
        if data.batch_dims != 2:
            raise ValueError(f"compute_advantage expects a [num_envs, time] batch, got batch_size={data.batch_size}")
        td = data.clone(False)
        task_id = self._task_ids(td)
        in_keys = [k for k in self.critic_network.in_keys]
        obs_td = td.select(*in_keys)
        values = self._critic_values(obs_td)
        next_td = td.get("next")
        last = next_td[:, -1].select(*in_keys, strict=False)
        done_last = next_td.get(self.tensor_keys.done)[:, -1].reshape(-1)
        for key in in_keys:
            if key not in last.keys():
                last.set(key, td.get(key)[:, -1])
            val = last.get(key)
            if val.is_floating_point():
                mask = done_last.reshape(done_last.shape + (1,) * (val.ndim - 1))
                last.set(key, torch.where(mask, torch.zeros_like(val), val))
        last_values = self._critic_values(last)
        next_values = torch.cat([values[:, 1:], last_values.unsqueeze(1)], dim=1)

        values_dn = self.denormalize_values(values, task_id)
        next_values_dn = self.denormalize_values(next_values, task_id)
        gae_td = TensorDict(
            {
                self.tensor_keys.value: values_dn,
                "next": {
                    self.tensor_keys.value: next_values_dn,
                    self.tensor_keys.reward: next_td.get(self.tensor_keys.reward),
                    self.tensor_keys.done: next_td.get(self.tensor_keys.done),
                    self.tensor_keys.terminated: next_td.get(self.tensor_keys.terminated),
                    "truncated": next_td.get("truncated"),
                },
            },
            batch_size=td.batch_size,
        )
        self.value_estimator(gae_td, time_dim=1)
        advantage = gae_td.get(self.tensor_keys.advantage)
        returns = gae_td.get(self.tensor_keys.value_target)
        if self.value_norm is not None:
            self.value_norm.update(returns, task_id)
            state_value = self.value_norm.normalize(values_dn, task_id)
            value_target = self.value_norm.normalize(returns, task_id)
        else:
            state_value, value_target = values_dn, returns
        td.set(self.tensor_keys.advantage, advantage)
        td.set(self.tensor_keys.value_target, value_target)
        td.set(self.tensor_keys.value, state_value)
        td.set("returns", returns)
        return td

