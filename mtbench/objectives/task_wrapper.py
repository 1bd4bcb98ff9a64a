"""Base class of the gradient-manipulation wrappers: per-task losses from a per-sample TorchRL loss.

A wrapper holds an inner :class:`~torchrl.objectives.LossModule` run with ``reduction="none"`` (the
wrapper sets it). From the per-sample ``loss_*`` terms and the batch's ``task_id`` it forms

* ``M``: the *manipulated* terms, per task (masked means, ``[K]``), for the parameter group ``params``:
  ``"critic"`` -> the terms whose graph reaches the critic parameters (``loss_critic`` of PPO, ``loss_qvalue``
  of SAC, ``loss`` of a DQN-style loss) on the critic parameters (MTBench's PPO configs),
  ``"actor"`` -> the other terms that reach the actor parameters, on the actor parameters,
  ``"all"`` -> the sum of all loss terms on all parameters;
* ``P``: the remaining (plain) terms, averaged over the batch as the inner loss would with ``"mean"``.

:meth:`backward` writes ``.grad`` on every inner parameter: the group gets ``method(M) + d mean(P)``, the
other parameters get the gradient of the plain mean of all terms. Subclasses implement the method either
from the ``[K, P]`` per-task gradient matrix (:meth:`_combine`, PCGrad/CAGrad) or as per-task loss weights
(:meth:`_task_weights`, FAMO: one backward pass). Gradients are *accumulated* into ``.grad`` like
``Tensor.backward`` (the trainer zeroes them before each update).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.utils import NestedKey
from torch import nn
from torchrl.objectives import LossModule

from ..utils import distributed
from .gradients import is_loss_key
from .param_groups import PARAM_GROUPS, available_groups, resolve_param_group, terms_reaching
from .per_task import check_task_ids, flat_task_ids, per_sample, task_counts, task_means, weighted_mean
from .task_gradients import (
    batched_per_task_gradients,
    cosine_stats,
    gram,
    grads_or_zeros,
    per_task_gradients,
    unflatten,
)

DIAGNOSTIC_KEYS = tuple(f"grad_cos_{g}_{s}" for g in ("actor", "critic") for s in ("mean", "min", "max"))


class TaskLosses:
    """Per-sample terms of one inner-loss call, reduced per task and over the batch (internal helper)."""

    def __init__(
        self,
        out: TensorDictBase,
        task_id: torch.Tensor,
        weights: torch.Tensor | None,
        num_tasks: int,
    ) -> None:
        self.names = [k for k in out.keys() if is_loss_key(k)]
        if not self.names:
            raise ValueError(f"the wrapped loss returned no 'loss' or 'loss_*' entry; keys: {list(out.keys())}")
        self.terms = {k: out.get(k) for k in self.names}  # as the loss returned them (graph inspection)
        n = task_id.numel()
        terms = [per_sample(out.get(k), n, k) for k in self.names]
        dtype = terms[0].dtype
        for t in terms[1:]:
            dtype = torch.promote_types(dtype, t.dtype)
        self.samples = torch.stack([t.to(dtype) for t in terms], dim=-1)  # [N, T]
        self.task_id = task_id
        self.weights = weights
        self.num_tasks = num_tasks
        self.counts = task_counts(task_id, num_tasks, None if weights is None else weights.to(self.samples.dtype))
        share = self.counts
        if distributed.is_active():  # torchrun: per-task means over every rank's samples
            self.counts = distributed.all_reduce_sum_(self.counts.detach().clone())
            share = self.counts / distributed.world_size()  # this rank's sums over it: the ranks' mean is the union's
        self.present = self.counts > 0
        self.per_task, _ = task_means(self.samples, task_id, num_tasks, weights, share)  # [K, T]
        if distributed.is_active():
            # the value of the union's per-task means, the gradient of this rank's share (averaged over the ranks)
            union = self.per_task.detach().clone()
            distributed.all_reduce_mean_([union])
            self.per_task = self.per_task + (union - self.per_task).detach()
        self.means = weighted_mean(self.samples, weights)  # [T]
        self.metrics = out.exclude(*self.names)

    def select(self, names: Sequence[str]) -> tuple[torch.Tensor | None, torch.Tensor | None]:
        """(per-task ``[K]``, batch mean ``[]``) of the sum of the terms ``names`` (``None`` if empty)."""
        idx = [i for i, k in enumerate(self.names) if k in names]
        if not idx:
            return None, None
        return _sum_columns(self.per_task, idx), _sum_columns(self.means, idx)


def _sum_columns(x: torch.Tensor, idx: Sequence[int]) -> torch.Tensor:
    # integer selects (views) rather than list indexing, which would copy an index list to the device
    out = x[..., idx[0]]
    for i in idx[1:]:
        out = out + x[..., i]
    return out


class TaskGradientWrapper(LossModule):
    """Common machinery of :class:`PCGrad`, :class:`CAGrad`, :class:`FAMO` and :class:`GradientDiagnostics`.

    Args:
        loss_module: a TorchRL ``LossModule`` whose ``reduction="none"`` output holds per-sample loss terms
            (``loss_*`` or ``loss`` entries: ``ClipPPOLoss``, ``SACLoss``, a DQN-style loss, mtbench's
            ``MTPPOLoss``/``MTGRPOLoss``/``MTSACLoss``, ...). Its ``reduction`` is set to ``"none"``.
        num_tasks: K.
        params: manipulated parameter group, ``"critic"`` (default, MTBench's PPO configs), ``"actor"`` or
            ``"all"``.
        diagnostics_every: compute the pairwise cosine similarities of the per-task actor and critic
            gradients every this many updates (0 = never); see :meth:`backward`.
        critic_keys: the loss terms that belong to the critic. ``None`` (default): found from the parameter
            groups -- the terms whose autograd graph reaches the critic parameters (``loss_critic`` of PPO,
            ``loss_qvalue`` of SAC, ``loss`` of a DQN-style loss); the actor terms are the other terms that reach
            the actor parameters; terms that reach neither (e.g. SAC's ``loss_alpha``) are never manipulated
            (except with ``params="all"``). A sequence of names fixes the critic terms instead (the actor terms
            are then all the others).
        task_loss_scale: factor applied to the per-task manipulated losses before the method (MTBench's
            PCGrad/CAGrad per-task critic losses omit rl_games' ``0.5 * critic_coef``: use ``1 / (0.5 *
            critic_coef)`` to reproduce their gradient scale exactly).

    The task index is read from the batch entry ``task_id`` (int64, batch-shaped, optional trailing 1): the
    inner loss's declared ``tensor_keys.task_id`` when it has one (mtbench's losses), else this wrapper's own
    key; ``wrapper.set_keys(task_id=...)`` renames both, so the wrapper and its loss never disagree.
    """

    @dataclass
    class _AcceptedKeys:
        """``task_id``: the batch entry holding the per-sample task index (used when the inner loss declares
        none)."""

        task_id: NestedKey = "task_id"

    #: True for methods built on the per-task gradient matrix (PCGrad, CAGrad), False for loss weighting.
    needs_task_gradients: bool = True

    def __init__(
        self,
        loss_module: LossModule,
        num_tasks: int,
        *,
        params: str = "critic",
        diagnostics_every: int = 0,
        critic_keys: Sequence[str] | None = None,
        task_loss_scale: float = 1.0,
    ) -> None:
        super().__init__()
        if not isinstance(loss_module, nn.Module):
            raise TypeError(f"loss_module must be a torch nn.Module (a TorchRL LossModule), got {type(loss_module)}")
        if int(num_tasks) < 1:
            raise ValueError(f"num_tasks must be >= 1, got {num_tasks}")
        if params not in PARAM_GROUPS:
            raise ValueError(f"unknown params group {params!r}; valid choices: {list(PARAM_GROUPS)}")
        if int(diagnostics_every) < 0:
            raise ValueError(f"diagnostics_every must be >= 0 (0 = off), got {diagnostics_every}")
        if hasattr(loss_module, "reduction"):
            loss_module.reduction = "none"
        self.loss_module = loss_module
        self.num_tasks = int(num_tasks)
        self.params = params
        self.diagnostics_every = int(diagnostics_every)
        self.critic_keys = None if critic_keys is None else tuple(critic_keys)
        self.task_loss_scale = float(task_loss_scale)
        self.num_updates = 0
        #: False when the caller schedules the diagnostics (:meth:`diagnostics_due`, :meth:`measure_diagnostics`,
        #: :meth:`count_update`) instead of :meth:`backward`: the CUDA-graphed minibatch update does, since a graph
        #: replay runs no Python (``MinibatchUpdate`` sets it)
        self.diagnostics_in_backward = True
        self.batched_backward = True  # False once a batched backward failed (then K passes every update)
        resolve_param_group(loss_module, params)  # validates that the group exists
        self._diag_groups: list[str] = []
        if self.diagnostics_every:
            for g in ("actor", "critic"):
                try:
                    resolve_param_group(loss_module, g)
                    self._diag_groups.append(g)
                except ValueError:
                    pass
            if not self._diag_groups:
                raise ValueError(
                    f"diagnostics need an actor and/or a critic network in {type(loss_module).__name__}; found none"
                )
        self._last_diagnostics: dict[str, torch.Tensor] = {}
        self._group_terms: dict[tuple[str, tuple[str, ...]], list[str]] = {}  # found once per term set

    # ------------------------------------------------------------------ keys; delegation to the inner loss
    def _inner_declares_task_id(self) -> bool:
        keys = getattr(self.loss_module, "_AcceptedKeys", None)
        return keys is not None and "task_id" in getattr(keys, "__dataclass_fields__", {})

    @property
    def task_id_key(self) -> NestedKey:
        """The batch entry read as the task index: the inner loss's ``tensor_keys.task_id`` when it declares one,
        else this wrapper's own ``task_id`` key."""
        if self._inner_declares_task_id():
            return self.loss_module.tensor_keys.task_id
        return self._tensor_keys.task_id

    def set_keys(self, **kwargs: Any) -> None:
        """Set tensordict keys: ``task_id`` is this wrapper's key *and* the inner loss's (when it declares one),
        every other key is the inner loss's."""
        if "task_id" in kwargs:
            task_id = kwargs.pop("task_id")
            super().set_keys(task_id=task_id)
            if self._inner_declares_task_id():
                self.loss_module.set_keys(task_id=task_id)
        if kwargs:
            self.loss_module.set_keys(**kwargs)

    @property
    def in_keys(self) -> list[NestedKey]:
        """The inner loss's ``in_keys`` plus the task index."""
        inner = list(getattr(self.loss_module, "in_keys", []) or [])
        return list(dict.fromkeys([*inner, self.task_id_key]))

    def make_value_estimator(self, *args: Any, **kwargs: Any) -> Any:
        return self.loss_module.make_value_estimator(*args, **kwargs)

    @property
    def value_estimator(self) -> Any:
        return self.loss_module.value_estimator

    @value_estimator.setter
    def value_estimator(self, value: Any) -> None:
        self.loss_module.value_estimator = value

    # ------------------------------------------------------------------ loss terms
    def _terms_on(self, group: str, losses: TaskLosses) -> list[str]:
        """The terms of ``losses`` whose graph reaches the parameters of ``group`` (``[]`` when the loss has no
        such group); found by graph inspection at the first call, then cached for this set of term names."""
        key = (group, tuple(losses.names))
        if key not in self._group_terms:
            found: list[str] = []
            if group in available_groups(self.loss_module):
                found = terms_reaching(losses.terms, resolve_param_group(self.loss_module, group))
            self._group_terms[key] = found
        return self._group_terms[key]

    def _group_term_names(self, group: str, losses: TaskLosses) -> list[str]:
        """The loss terms manipulated for ``group``: ``all`` -> every term; ``critic`` -> the critic terms
        (``critic_keys``, or the terms that reach the critic parameters); ``actor`` -> the terms other than the
        critic's that reach the actor parameters (all the others when ``critic_keys`` is given)."""
        names = losses.names
        if group == "all":
            return list(names)
        if self.critic_keys is not None:
            critic = [k for k in names if k in self.critic_keys]
            actor = [k for k in names if k not in critic]
        else:
            critic = self._terms_on("critic", losses)
            actor = [k for k in self._terms_on("actor", losses) if k not in critic]
        return critic if group == "critic" else actor

    def _sample_weights(self, td: TensorDictBase, numel: int) -> torch.Tensor | None:
        keys_fn = getattr(self.loss_module, "_loss_mask_keys", None)
        if not callable(keys_fn):
            return None
        mask = None
        for key in keys_fn():
            m = td.get(key, None)
            if m is None:
                continue
            m = m.reshape(-1)
            if m.numel() != numel:
                raise ValueError(f"loss mask {key!r} has {m.numel()} entries for {numel} samples")
            m = m.bool()
            mask = m if mask is None else mask & m
        return mask

    def _task_losses(self, td: TensorDictBase) -> TaskLosses:
        key = self.task_id_key
        task_id = td.get(key, None)
        if task_id is None:
            raise KeyError(f"{type(self).__name__}: the batch has no {key!r} entry (per-sample task index)")
        out = self.loss_module(td)
        numel = task_id.numel()
        ids = flat_task_ids(task_id, numel)
        weights = self._sample_weights(td, numel)
        if weights is not None:
            ids = torch.where(weights, ids, torch.zeros_like(ids))  # padded rows may hold garbage ids
        check_task_ids(ids, self.num_tasks)
        losses = TaskLosses(out, ids, weights, self.num_tasks)
        if self.params != "all" and not self._group_term_names(self.params, losses):
            named = self.critic_keys is not None and self.params == "critic"
            which = (f"a term named {list(self.critic_keys or ())}" if named
                     else f"a loss term whose graph reaches the {self.params} parameters")
            raise ValueError(
                f"params={self.params!r} needs {which} in the output of {type(self.loss_module).__name__}; loss "
                f"terms: {losses.names} (use params='actor' or 'all', or set critic_keys)"
            )
        return losses

    def _metrics(self, losses: TaskLosses, *, detach: bool) -> TensorDict:
        out = TensorDict({}, batch_size=[])
        for i, name in enumerate(losses.names):
            mean = losses.means[i]
            out.set(name, mean.detach() if detach else mean)
        for key, value in losses.metrics.items():
            if isinstance(value, torch.Tensor):
                value = value.detach()
                out.set(key, value.float().mean() if value.numel() != 1 else value.reshape(()))
            elif isinstance(value, TensorDictBase):
                out.set(key, value.detach().apply(lambda x: x.float().mean(), batch_size=[]))
        for i, name in enumerate(losses.names):
            out.set(f"task_{name}", losses.per_task[:, i].detach())
        out.set("task_count", losses.counts.detach())
        return out

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Inner loss terms reduced to batch means (differentiable ``loss_*``), the inner metrics, and
        per-task ``task_loss_*`` ``[K]`` means and ``task_count`` ``[K]`` (detached)."""
        out = self._metrics(self._task_losses(tensordict), detach=False)
        for key, value in self._extra_metrics().items():
            out.set(key, value)
        return out

    # ------------------------------------------------------------------ CUDA-graph capture
    @property
    def cuda_graph_safe(self) -> bool:
        """Whether one :meth:`backward` may be captured in a CUDA graph and replayed (the trainer's graphed
        minibatch update): it is sync-free with fixed shapes and its state lives in device tensors. The diagnostics'
        Python schedule then runs outside the graph (``diagnostics_in_backward = False``; ``MinibatchUpdate``
        measures eagerly between replays and the replayed metrics read the measurement's tensors in place)."""
        return True

    def cuda_graph_generators(self) -> list[torch.Generator]:
        """Non-default random generators :meth:`backward` draws from (registered with a captured graph)."""
        return []

    # ------------------------------------------------------------------ checkpoint state
    def get_extra_state(self) -> dict[str, Any]:
        """The update counter (it schedules the diagnostics) and the latest diagnostics (reported at every
        update), so that a resumed run measures and reports exactly as the uninterrupted one."""
        return {"num_updates": self.num_updates,
                "last_diagnostics": {k: v.clone() for k, v in self._last_diagnostics.items()}}

    def set_extra_state(self, state: dict[str, Any]) -> None:
        self.num_updates = int(state["num_updates"])
        device = next(iter(self.loss_module.parameters())).device  # checkpoints are loaded on the CPU
        for key, value in state["last_diagnostics"].items():
            self._store_diagnostic(key, value.to(device))

    # ------------------------------------------------------------------ method hooks
    def _combine(self, grads: torch.Tensor, gram_matrix: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
        """Manipulated gradient ``[P]`` from the per-task gradient matrix ``[K, P]`` (PCGrad, CAGrad)."""
        raise NotImplementedError

    def _group_loss(self, task_losses: torch.Tensor, batch_mean: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
        """Scalar loss whose gradient is the group's update, for methods without per-task gradients (FAMO:
        a weighted sum of ``task_losses [K]``; diagnostics only: ``batch_mean``)."""
        raise NotImplementedError

    def _extra_metrics(self) -> dict[str, torch.Tensor]:
        return {}

    # ------------------------------------------------------------------ backward
    def diagnostics_due(self) -> bool:
        """Whether the next update is measured (every ``diagnostics_every`` updates, the first one included)."""
        return self.diagnostics_every > 0 and self.num_updates % self.diagnostics_every == 0

    def count_update(self) -> None:
        """Advance the update counter that schedules the diagnostics (done by :meth:`backward` itself unless
        ``diagnostics_in_backward`` is False)."""
        self.num_updates += 1

    def measure_diagnostics(self, tensordict: TensorDictBase) -> None:
        """Measure the gradient-conflict diagnostics on ``tensordict`` now (eager; no ``.grad`` is written), as
        :meth:`backward` does when :meth:`diagnostics_due`: for callers that schedule them themselves."""
        if not self.diagnostics_every:
            raise RuntimeError("measure_diagnostics needs diagnostics_every > 0")
        losses = self._task_losses(tensordict)
        self._diagnostics(losses, losses.present)

    def _store_diagnostic(self, key: str, value: torch.Tensor) -> None:
        """Keep ``value`` under ``key``, in place when the key exists (a captured graph reads that tensor)."""
        held = self._last_diagnostics.get(key)
        if held is not None and held.shape == value.shape and held.device == value.device:
            held.copy_(value.detach())
        else:
            self._last_diagnostics[key] = value.detach().clone()

    def backward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Run the inner loss on ``tensordict``, accumulate the manipulated gradients into ``.grad`` of all
        inner parameters, and return detached metrics: ``loss_*`` batch means, the inner metrics,
        ``task_loss_*``/``task_count`` (``[K]``), method metrics, and -- when diagnostics are on -- the
        scalars ``grad_cos_{actor,critic}_{mean,min,max}`` (most recent measurement, refreshed every
        ``diagnostics_every`` updates, so the metric keys are the same at every update)."""
        losses = self._task_losses(tensordict)
        manip_names = self._group_term_names(self.params, losses)
        plain_names = [k for k in losses.names if k not in manip_names]
        m_task, m_mean = losses.select(manip_names)
        _, p_mean = losses.select(plain_names)
        if m_task is None:
            raise ValueError(f"no loss term to manipulate for params={self.params!r}; loss terms: {losses.names}")
        m_task = m_task * self.task_loss_scale
        present = losses.present

        reuse: torch.Tensor | None = None  # per-task gradient matrix of the manipulated group, if computed
        if self.diagnostics_in_backward and self.diagnostics_due():
            reuse = self._diagnostics(losses, present)

        # resolved at every call: .to()/load_state_dict on TensorDictParams may replace Parameter objects
        group = resolve_param_group(self.loss_module, self.params)
        ids = {id(p) for p in group}
        rest = [p for p in resolve_param_group(self.loss_module, "all") if id(p) not in ids]
        if self.needs_task_gradients:
            if reuse is None:
                reuse = self._task_gradients(m_task, group)
            direction = self._combine(reuse, gram(reuse), present)
            grads_group = [a + b for a, b in zip(grads_or_zeros(p_mean, group), unflatten(direction, group))]
        else:
            target = self._group_loss(m_task, m_mean, present)
            target = target if p_mean is None else target + p_mean
            grads_group = grads_or_zeros(target, group, retain_graph=bool(rest))
        if rest:
            plain = m_mean if p_mean is None else m_mean + p_mean
            grads_rest = grads_or_zeros(plain, rest, retain_graph=False)
        else:
            grads_rest = []
        for p, g in zip([*group, *rest], [*grads_group, *grads_rest]):
            if p.grad is None:
                # in the parameter's own strides, as ``backward()`` lays out ``.grad`` (the gradient of a
                # transposed use comes out transposed; fused optimizers refuse grads strided unlike params)
                p.grad = torch.empty_like(p).copy_(g)
            else:
                p.grad.add_(g)
        if self.diagnostics_in_backward:
            self.count_update()
        metrics = self._metrics(losses, detach=True)
        for key, value in {**self._last_diagnostics, **self._extra_metrics()}.items():
            metrics.set(key, value)
        return metrics

    def _task_gradients(self, task_losses: torch.Tensor, params: list[torch.Tensor]) -> torch.Tensor:
        """``[K, P]`` per-task gradient matrix: one batched backward pass while that works for this loss; after
        the first failure (an op without a batching rule, e.g. compiled networks) ``K`` passes, without retrying."""
        grads = batched_per_task_gradients(task_losses, params) if self.batched_backward else None
        if grads is None:
            self.batched_backward = False
            grads = per_task_gradients(task_losses, params, batched=False)
        distributed.all_reduce_mean_([grads])  # torchrun: every task's gradient over all ranks' samples
        return grads

    def _diagnostics(self, losses: TaskLosses, present: torch.Tensor) -> torch.Tensor | None:
        """Cosine statistics of the per-task actor/critic gradients; returns the manipulated group's
        gradient matrix when it coincides with one of them (so it is not computed twice)."""
        reuse = None
        for g in self._diag_groups:
            per_task, _ = losses.select(self._group_term_names(g, losses))
            params = resolve_param_group(self.loss_module, g)
            if per_task is None:
                stats = torch.full((3,), float("nan"), device=present.device)
            else:
                grads = self._task_gradients(per_task, params)
                stats = cosine_stats(gram(grads), present)
                if self.needs_task_gradients and self.params == g:
                    reuse = grads * self.task_loss_scale
            for name, value in zip(("mean", "min", "max"), stats.unbind(0)):
                self._store_diagnostic(f"grad_cos_{g}_{name}", value)
        return reuse
