"""Per-task value-normalised GAE as a TorchRL value estimator (MTBench's MT-PPO advantages)."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModule
from tensordict.utils import NestedKey
from torchrl.objectives.value import ValueEstimatorBase
from torchrl.objectives.value.functional import vec_generalized_advantage_estimate

from ..transforms.running_mean_std import PerTaskRunningMeanStd


def rollout_time_dim(estimator: ValueEstimatorBase, tensordict: TensorDictBase, time_dim: int | None) -> int:
    """The time dimension of a ``[*B, T]`` rollout (TorchRL's rule: ``time_dim``, the dim named ``"time"``, else
    the last); the estimators here need it to be the last batch dimension."""
    if tensordict.batch_dims < 1:
        raise ValueError(
            f"{type(estimator).__name__} expects a [*B, T] rollout, got batch_size={tensordict.batch_size}"
        )
    dim = estimator._get_time_dim(time_dim, tensordict)
    if dim != tensordict.batch_dims - 1:
        raise ValueError(
            f"{type(estimator).__name__} expects time as the last batch dimension of the rollout ([*B, T]); got "
            f"time_dim={dim} for batch_size={tuple(tensordict.batch_size)}"
        )
    return dim


def task_ids(tensordict: TensorDictBase, key: NestedKey) -> torch.Tensor:
    """The batch-shaped task index (a trailing singleton dim is dropped)."""
    task_id = tensordict.get(key, None)
    if task_id is None:
        raise KeyError(f"the rollout has no task index {key!r} (set it with set_keys(task_id=...))")
    return task_id.reshape(tensordict.batch_size)


def last_next_inputs(
    tensordict: TensorDictBase, in_keys: list[NestedKey], done_key: NestedKey, time_dim: int
) -> TensorDictBase:
    """The value network's inputs at the last ``("next", ...)`` step of a ``[*B, T]`` rollout (``[*B]``), for the
    bootstrap at the end of the window: entries missing from ``"next"`` (e.g. a constant ``task_id``) are taken from
    the last step; floating entries of rows done at the last step (NaN under TorchRL's native autoreset) are zeroed,
    so that the network sees finite inputs (their value must be masked by the caller)."""
    next_td = tensordict.get("next")
    last = next_td[..., -1].select(*in_keys, strict=False)
    done_last = next_td.get(done_key).select(time_dim, -1).reshape(last.batch_size)
    for key in in_keys:
        if key not in last.keys(include_nested=True):
            last.set(key, tensordict.get(key)[..., -1])
        val = last.get(key)
        if val.is_floating_point():
            mask = done_last.reshape(done_last.shape + (1,) * (val.ndim - done_last.ndim))
            last.set(key, torch.where(mask, torch.zeros_like(val), val))
    return last


class PerTaskGAE(ValueEstimatorBase):
    """GAE on a native-autoreset multi-task rollout whose critic predicts per-task *normalised* values.

    ``estimator(rollout)`` on a ``[*B, T]`` rollout (time last), under ``no_grad`` and without host
    synchronisation:

    1. critic values of ``observation[..., t]`` for every ``t`` and of the last ``("next", observation)``; rows
       that are done at the last step have NaN next observations (TorchRL's native autoreset): they are zeroed
       and their value is masked. ``V(s_{t+1}) = V(observation[..., t + 1])`` for every non-done step;
    2. the values are de-normalised per task with :attr:`value_norm` (rl_games clamps normalised values to
       ``value_norm_clip``);
    3. GAE(``gamma``, ``lmbda``) with the truncation bootstrap ``r += gamma * V(s_t)`` of
       ``GAE(auto_reset_env=True)`` (the env returns the next episode's first observation on done steps);
    4. :attr:`value_norm` is updated with the returns; ``state_value`` (old values, for value clipping) and
       ``value_target`` are written normalised with the updated statistics, ``advantage`` and ``returns``
       un-normalised.

    The per-task statistics (``value_norm.count/mean/var``) are buffers of this estimator, hence part of the
    owning loss's ``state_dict`` (``_value_estimator.value_norm.*``). With ``normalize_value=False`` it is plain
    GAE with truncation bootstrap.

    Args:
        gamma, lmbda: GAE parameters (0.99, 0.95).
        value_network: the critic (``state_value`` = normalised value).
        num_tasks: K.
        normalize_value: per-task value normalisation (MTBench: True).
        value_norm_clip: clamp of normalised values (rl_games: 5); ``None`` disables.
        value_norm_eps: variance epsilon of the statistics (rl_games: 1e-5).
        device: device of the statistics.
    """

    @dataclass
    class _AcceptedKeys:
        """The keys of :class:`ValueEstimatorBase` (repeated: TorchRL's ``set_keys`` accepts only a class's own
        fields) plus ``truncated`` (``("next", truncated)`` drives the
        bootstrap), ``task_id`` (per-sample task index) and ``returns`` (written: un-normalised returns)."""

        advantage: NestedKey = "advantage"
        value_target: NestedKey = "value_target"
        value: NestedKey = "state_value"
        reward: NestedKey = "reward"
        done: NestedKey = "done"
        terminated: NestedKey = "terminated"
        steps_to_next_obs: NestedKey = "steps_to_next_obs"
        sample_log_prob: NestedKey = "action_log_prob"
        truncated: NestedKey = "truncated"
        task_id: NestedKey = "task_id"
        returns: NestedKey = "returns"

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys

    def __init__(
        self,
        *,
        gamma: float,
        lmbda: float,
        value_network: TensorDictModule,
        num_tasks: int,
        normalize_value: bool = True,
        value_norm_clip: float | None = 5.0,
        value_norm_eps: float = 1e-5,
        device: torch.device | str | None = None,
    ) -> None:
        if value_network is None:
            raise ValueError("PerTaskGAE needs the critic as value_network")
        super().__init__(value_network=value_network, device=device)
        self.gamma = float(gamma)
        self.lmbda = float(lmbda)
        self.num_tasks = int(num_tasks)
        self.value_norm: PerTaskRunningMeanStd | None = (
            PerTaskRunningMeanStd(num_tasks, 1, eps=value_norm_eps, clip=value_norm_clip, device=device)
            if normalize_value
            else None
        )

    @property
    def in_keys(self) -> list[NestedKey]:
        keys = list(super().in_keys)
        keys += [("next", self.tensor_keys.truncated), self.tensor_keys.task_id]
        return list(dict.fromkeys(keys))

    @property
    def out_keys(self) -> list[NestedKey]:
        k = self.tensor_keys
        return [k.advantage, k.value_target, k.value, k.returns]

    def _values(self, observation_td: TensorDictBase, params: TensorDictBase | None) -> torch.Tensor:
        if params is not None:
            with params.to_module(self.value_network, preserve_module_state=False):
                return self.value_network(observation_td).get(self.tensor_keys.value)
        return self.value_network(observation_td).get(self.tensor_keys.value)

    def _denormalize(self, values: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        return values if self.value_norm is None else self.value_norm.denormalize(values, task_id)

    @torch.no_grad()
    def forward(
        self,
        tensordict: TensorDictBase,
        *,
        params: TensorDictBase | None = None,
        target_params: TensorDictBase | None = None,
        time_dim: int | None = None,
    ) -> TensorDictBase:
        """Write ``advantage``, ``value_target``, ``state_value`` and ``returns`` into ``tensordict`` (returned).

        ``params`` (optional): functional critic parameters (what a TorchRL loss passes); ``target_params`` is
        accepted for API compatibility and unused (no target critic).
        """
        tdim = rollout_time_dim(self, tensordict, time_dim)
        keys = self.tensor_keys
        task_id = task_ids(tensordict, keys.task_id)
        in_keys = list(self.value_network.in_keys)
        values = self._values(tensordict.select(*in_keys), params)
        next_td = tensordict.get("next")
        done = next_td.get(keys.done)
        last = last_next_inputs(tensordict, in_keys, keys.done, tdim)  # rows done at T-1: masked below
        last_values = self._values(last, params).unsqueeze(tdim)
        index = (slice(None),) * tdim + (slice(1, None),)
        next_values = torch.cat([values[index], last_values], dim=tdim)

        values_dn = self._denormalize(values, task_id)
        next_values_dn = self._denormalize(next_values, task_id)
        reward = next_td.get(keys.reward)
        truncated = next_td.get(keys.truncated)
        # truncation bootstrap of GAE(auto_reset_env=True), without its host-side ``truncated.any()``
        reward = reward + self.gamma * values_dn * truncated.to(values_dn.dtype)
        advantage, returns = vec_generalized_advantage_estimate(
            self.gamma, self.lmbda, values_dn, next_values_dn, reward, done=done, terminated=done, time_dim=tdim
        )
        if self.value_norm is not None:
            self.value_norm.update(returns, task_id)
            state_value = self.value_norm.normalize(values_dn, task_id)
            value_target = self.value_norm.normalize(returns, task_id)
        else:
            state_value, value_target = values_dn, returns
        tensordict.set(keys.advantage, advantage)
        tensordict.set(keys.value_target, value_target)
        tensordict.set(keys.value, state_value)
        tensordict.set(keys.returns, returns)
        return tensordict


__all__ = ["PerTaskGAE", "last_next_inputs", "rollout_time_dim", "task_ids"]
