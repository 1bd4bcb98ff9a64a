"""TorchRL transform normalising the state part of ``observation`` with per-task running statistics."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torchrl.data import Composite, TensorSpec, Unbounded
from torchrl.envs.transforms import Transform

from .running_mean_std import PerTaskRunningMeanStd


class PerTaskObservationNorm(Transform):
    """Normalise ``observation[..., :S]`` per task as ``(x - mu_t) / sqrt(var_t + eps)`` (no clamp).

    This is MTBench's per-task input normalisation (``MTModelNetwork.norm_obs``): one running mean/std per
    task over the state part only; the trailing one-hot task id (the last ``num_tasks`` entries) is passed
    through untouched. While not frozen, every observation the transform sees (reset and step outputs) is
    merged into the statistics of its task *before* being normalised; :meth:`freeze` stops the updates (for
    evaluation), :meth:`unfreeze` resumes them. Statistics live in buffers (``stats.count/mean/var``), so a
    ``state_dict`` round trip restores them. Rows with non-finite values are not merged into the statistics.

    Works appended to any env that emits ``observation`` ``[..., S + K]`` and ``task_id`` (``[...]`` or
    ``[..., 1]``, int64)::

        env = TransformedEnv(base_env, PerTaskObservationNorm(num_tasks=base_env.num_tasks))

    Args:
        num_tasks: K, the size of the trailing one-hot.
        state_dim: S. ``None`` infers it from the observation spec (``obs_dim - K``) or the first observation.
        in_keys: observation entries to normalise (default ``["observation"]``); all share the statistics.
        task_id_key: entry holding the task index.
        eps: variance epsilon (MTBench: 1e-8).
        frozen: start frozen.
        device: device of the statistics (defaults to the parent env's device when attached).
    """

    def __init__(
        self,
        num_tasks: int,
        state_dim: int | None = None,
        *,
        in_keys: list[NestedKey] | None = None,
        task_id_key: NestedKey = "task_id",
        eps: float = 1e-8,
        frozen: bool = False,
        device: torch.device | str | None = None,
    ) -> None:
        if in_keys is None:
            in_keys = ["observation"]
        super().__init__(in_keys=in_keys, out_keys=list(in_keys))
        self.num_tasks = int(num_tasks)
        self.task_id_key = task_id_key
        self.frozen = bool(frozen)
        self.stats = PerTaskRunningMeanStd(num_tasks, state_dim or 0, eps=eps, device=device)

    # ------------------------------------------------------------------ control
    def freeze(self) -> PerTaskObservationNorm:
        """Stop updating the statistics (normalisation keeps using the current ones)."""
        self.frozen = True
        return self

    def unfreeze(self) -> PerTaskObservationNorm:
        """Resume updating the statistics."""
        self.frozen = False
        return self

    @property
    def state_dim(self) -> int:
        """S (0 until known)."""
        return self.stats.dim

    # ------------------------------------------------------------------ core
    def _task_id(self, td: TensorDictBase) -> torch.Tensor:
        task_id = td.get(self.task_id_key, None)
        if task_id is None:
            raise KeyError(f"{type(self).__name__}: '{self.task_id_key}' not found in {list(td.keys())}")
        if task_id.ndim and task_id.shape[-1] == 1 and task_id.ndim == td.batch_dims + 1:
            task_id = task_id.squeeze(-1)
        return task_id

    def normalize(self, obs: torch.Tensor, task_id: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """Update the statistics (unless frozen; rows where ``mask`` is False are not merged) and return
        the normalised observation."""
        if self.stats.dim == 0:
            self.stats._materialize(obs.shape[-1] - self.num_tasks)
        s = self.stats.dim
        if obs.shape[-1] != s + self.num_tasks:
            raise ValueError(
                f"observation has {obs.shape[-1]} features, expected state_dim + num_tasks = {s} + {self.num_tasks}"
            )
        if self.stats.count.device != obs.device:
            self.stats.to(obs.device)
        state, one_hot = obs[..., :s], obs[..., s:]
        if not self.frozen:
            self.stats.update(state, task_id, mask=mask)
        return torch.cat([self.stats.normalize(state, task_id), one_hot], dim=-1)

    def _normalize_td(self, td: TensorDictBase, mask: torch.Tensor | None = None) -> TensorDictBase:
        task_id = self._task_id(td)
        for in_key, out_key in zip(self.in_keys, self.out_keys):
            obs = td.get(in_key, None)
            if obs is None:
                if not self.missing_tolerance:
                    raise KeyError(f"{type(self).__name__}: '{in_key}' not found in {list(td.keys())}")
                continue
            td.set(out_key, self.normalize(obs, task_id, mask))
        return td

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        return self._normalize_td(next_tensordict)

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        mask = None
        if tensordict is not None:
            reset = tensordict.get("_reset", None)
            if reset is not None:
                mask = reset.reshape(tensordict_reset.batch_size)
        return self._normalize_td(tensordict_reset, mask)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Normalise ``tensordict`` outside an env (e.g. offline data); updates the stats unless frozen."""
        return self._normalize_td(tensordict)

    # ------------------------------------------------------------------ specs
    def transform_observation_spec(self, observation_spec: TensorSpec) -> TensorSpec:
        if not isinstance(observation_spec, Composite):
            return observation_spec
        for key in self.in_keys:
            spec = observation_spec.get(key, None)
            if spec is None:
                continue
            if self.stats.dim == 0:
                self.stats._materialize(int(spec.shape[-1]) - self.num_tasks)
                if self.stats.count.device != spec.device and spec.device is not None:
                    self.stats.to(spec.device)
            observation_spec[key] = Unbounded(shape=spec.shape, dtype=spec.dtype, device=spec.device)
        return observation_spec

    def extra_repr(self) -> str:
        return f"num_tasks={self.num_tasks}, state_dim={self.state_dim}, frozen={self.frozen}"

    def __repr__(self) -> str:
        return f"{type(self).__name__}(in_keys={self.in_keys}, {self.extra_repr()})"
