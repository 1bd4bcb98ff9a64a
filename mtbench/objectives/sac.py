"""MT-SAC loss (MTBench ``MTSACAgent``) on top of TorchRL's ``SACLoss``.

TorchRL's ``SACLoss`` (version 2: twin Q networks, no V network) does the work: functional actor and Q
parameters, the Q networks evaluated with ``vmap``, target Q parameters (``target_qvalue_network_params``,
moved with ``torchrl.objectives.SoftUpdate``), the target ``y = r + gamma^k (1 - terminated) [min_j Qbar_j(s',
a') - alpha log pi(a'|s')]`` through its TD(0) value estimator (``gamma^k`` with ``k = steps_to_next_obs``: the
n-step transitions of :class:`~mtbench.objectives.nstep.NStepTransitions`), the Q loss and the actor loss. This
subclass adds what MTBench's MT-SAC has on top:

* **per-task (disentangled) temperatures**: ``log_alpha`` has shape ``[num_tasks]``; every sample uses its task's
  ``alpha`` in the target and in the actor loss, and the temperature loss of a sample only reaches its task's
  ``log_alpha`` (MTBench ``use_disentangled_alpha``);
* MTBench's temperature loss ``alpha_t (-log pi - H)`` (``alpha_loss="alpha"``, default) or TorchRL's / the
  SAC paper's ``-log alpha_t (log pi + H)`` (``alpha_loss="log_alpha"``); target entropy ``H = -|A|``;
* the MSE Q loss (``loss_function="l2"``, MTBench's ``nn.MSELoss`` summed over the two Q networks).

With one task, ``alpha_loss="log_alpha"`` and the same loss function it computes exactly TorchRL's ``SACLoss``
(tests/test_sac.py). ``reduction="none"`` returns per-sample ``loss_actor``, ``loss_qvalue`` and ``loss_alpha``
(for the gradient-manipulation wrappers); the metrics ``alpha`` (batch mean of the samples' temperatures) and
``entropy`` (batch mean of ``-log pi``) are scalars in every mode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import ProbabilisticTensorDictSequential, TensorDictModule
from tensordict.utils import NestedKey
from torch import nn
from torchrl.data import TensorSpec
from torchrl.objectives import SACLoss
from torchrl.objectives.utils import ValueEstimators

ALPHA_LOSSES = ("alpha", "log_alpha")
_VALID_REDUCTIONS = ("mean", "sum", "none")


class MTSACLoss(SACLoss):
    """Multi-task SAC with one temperature per task.

    Use it like TorchRL's ``SACLoss``: ``loss(batch)`` on replay samples holding ``observation``, ``action``,
    ``task_id`` and ``("next", observation / task_id / reward / done / terminated)`` (plus ``steps_to_next_obs``
    for n-step transitions); the returned ``loss_*`` terms are summed for the total loss (each reaches only its
    own parameters: actor, Q networks, temperatures). Update the target Q parameters after every optimizer step
    with ``torchrl.objectives.SoftUpdate(loss, tau=...)``.

    Args:
        actor_network: stochastic actor (``observation``, ``task_id`` -> ``loc``, ``scale``; a tanh-squashed
            distribution, e.g. :func:`mtbench.trainer.soft_actor_critic.make_sac_actor`).
        qvalue_network: ``Q(s, a)`` module writing ``state_action_value`` (or a list of ``num_qvalue_nets``
            modules with independent initial parameters; a single module is copied and re-initialised by
            TorchRL).
        num_tasks: K, the number of temperatures.
        num_qvalue_nets: number of Q networks (2: twin Q).
        loss_function: Q loss, ``"l2"`` (MTBench), ``"l1"`` or ``"smooth_l1"`` (TorchRL's default).
        alpha_init: initial temperature of every task (MTBench ``init_alpha``: 1).
        min_alpha, max_alpha: optional clamp of the temperatures.
        fixed_alpha: keep the temperatures at ``alpha_init`` (MTBench ``learnable_temperature: False``).
        target_entropy: ``H`` of the temperature loss; ``"auto"``: ``-|A|`` from the actor's action spec.
        per_task_alpha: one temperature per task (default) or one shared scalar temperature.
        alpha_loss: ``"alpha"`` (MTBench, default) or ``"log_alpha"`` (TorchRL).
        gamma: discount of the TD(0) value estimator (``gamma ** steps_to_next_obs`` for n-step transitions).
        action_spec: the action spec (only for ``target_entropy="auto"`` when the actor has no spec).
        separate_losses: as in ``SACLoss`` (parameters shared by actor and Q networks trained by the actor loss
            only).
        reduction: ``"mean"`` (default), ``"sum"`` or ``"none"`` (per-sample ``loss_*``).
        deactivate_vmap: evaluate the Q networks in a loop instead of ``vmap``.
    """

    @dataclass
    class _AcceptedKeys(SACLoss._AcceptedKeys):
        """Keys of ``SACLoss`` (``action``, ``value``, ``state_action_value``, ``log_prob``, ``priority``,
        ``reward``, ``done``, ``terminated``, ``priority_weight``) plus:

        Attributes:
            task_id: per-sample task index (int64, batch-shaped, optional trailing 1): selects the temperature.
            steps_to_next_obs: per-sample number of env steps ``k`` between ``observation`` and
                ``("next", observation)`` (n-step transitions); the target discounts by ``gamma ** k``. Optional
                (absent: one step).
        """

        task_id: NestedKey = "task_id"
        steps_to_next_obs: NestedKey = "steps_to_next_obs"

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys

    def __init__(
        self,
        actor_network: ProbabilisticTensorDictSequential,
        qvalue_network: TensorDictModule | Sequence[TensorDictModule],
        *,
        num_tasks: int,
        num_qvalue_nets: int = 2,
        loss_function: str = "l2",
        alpha_init: float = 1.0,
        min_alpha: float | None = None,
        max_alpha: float | None = None,
        fixed_alpha: bool = False,
        target_entropy: float | str = "auto",
        per_task_alpha: bool = True,
        alpha_loss: str = "alpha",
        gamma: float = 0.99,
        action_spec: TensorSpec | None = None,
        separate_losses: bool = False,
        reduction: str = "mean",
        deactivate_vmap: bool = False,
    ) -> None:
        if int(num_tasks) < 1:
            raise ValueError(f"num_tasks must be >= 1, got {num_tasks}")
        if alpha_loss not in ALPHA_LOSSES:
            raise ValueError(f"unknown alpha_loss {alpha_loss!r}; valid choices: {list(ALPHA_LOSSES)}")
        if reduction not in _VALID_REDUCTIONS:
            raise ValueError(f"unknown reduction {reduction!r}; valid choices: {list(_VALID_REDUCTIONS)}")
        if not (alpha_init > 0 and math.isfinite(alpha_init)):
            raise ValueError(f"alpha_init must be a finite number > 0, got {alpha_init}")
        if not 0.0 < gamma <= 1.0:
            raise ValueError(f"gamma must be in (0, 1], got {gamma}")
        self.num_tasks = int(num_tasks)
        self.per_task_alpha = bool(per_task_alpha)
        self.alpha_loss_type = alpha_loss
        super().__init__(
            actor_network,
            list(qvalue_network) if isinstance(qvalue_network, (list, tuple)) else qvalue_network,
            num_qvalue_nets=num_qvalue_nets,
            loss_function=loss_function,
            alpha_init=alpha_init,
            min_alpha=min_alpha,
            max_alpha=max_alpha,
            action_spec=action_spec,
            fixed_alpha=fixed_alpha,
            target_entropy=target_entropy,
            delay_actor=False,
            delay_qvalue=True,
            separate_losses=separate_losses,
            reduction=reduction,
            deactivate_vmap=deactivate_vmap,
            scalar_output_mode="exclude",  # this forward always returns the scalar metrics
        )
        shape = (self.num_tasks,) if self.per_task_alpha else ()
        log_alpha = torch.full(shape, math.log(alpha_init), device=self.log_alpha.device)
        if fixed_alpha:
            self.log_alpha = log_alpha  # a buffer, as in SACLoss
        else:
            self.log_alpha = nn.Parameter(log_alpha)
        self._alpha_override: torch.Tensor | None = None
        self.make_value_estimator(ValueEstimators.TD0, gamma=gamma)

    # ------------------------------------------------------------------ keys and value estimator
    def _set_in_keys(self) -> None:
        super()._set_in_keys()
        if getattr(self, "per_task_alpha", True):
            self._in_keys = list(dict.fromkeys([*self._in_keys, self.tensor_keys.task_id]))

    def _forward_value_estimator_keys(self, **kwargs) -> None:
        super()._forward_value_estimator_keys(**kwargs)
        estimator = getattr(self, "_value_estimator", None)
        if estimator is not None and "steps_to_next_obs" in estimator._AcceptedKeys.__dataclass_fields__:
            estimator.set_keys(steps_to_next_obs=self.tensor_keys.steps_to_next_obs)

    # ------------------------------------------------------------------ temperatures
    def _task_ids(self, tensordict: TensorDictBase) -> torch.Tensor | None:
        task_id = tensordict.get(self.tensor_keys.task_id, None)
        if task_id is None:
            if self.per_task_alpha:
                raise KeyError(f"{type(self).__name__}: per-task temperatures need the task index "
                               f"{self.tensor_keys.task_id!r} in the batch (loss.set_keys(task_id=...) renames it)")
            return None
        return task_id.reshape(tensordict.batch_size).long()

    def _clamped_log_alpha(self) -> torch.Tensor:
        if self.min_log_alpha is not None or self.max_log_alpha is not None:
            self.log_alpha.data.clamp_(self.min_log_alpha, self.max_log_alpha)
        return self.log_alpha

    def _sample_log_alpha(self, task_id: torch.Tensor | None, batch_size: torch.Size) -> torch.Tensor:
        """Every sample's ``log alpha`` (differentiable w.r.t. its task's entry only)."""
        log_alpha = self._clamped_log_alpha()
        if self.per_task_alpha:
            return log_alpha[task_id]
        return log_alpha.expand(batch_size)

    @property
    def _alpha(self) -> torch.Tensor:
        """The temperature the inherited ``SACLoss`` methods multiply with: inside :meth:`forward`, every
        sample's (shaped for the method being run); outside, the temperatures (``[K]``, or a scalar)."""
        if self._alpha_override is not None:
            return self._alpha_override
        with torch.no_grad():
            return self._clamped_log_alpha().exp()

    @property
    def alphas(self) -> torch.Tensor:
        """The current temperatures ``exp(log_alpha)`` (``[K]``, or a scalar), detached."""
        with torch.no_grad():
            return self._clamped_log_alpha().exp()

    def alpha_loss(self, log_prob: torch.Tensor, task_id: torch.Tensor | None = None) -> torch.Tensor:
        """Per-sample temperature loss: ``alpha_t (-log pi - H)`` (``alpha_loss="alpha"``) or
        ``-log alpha_t (log pi + H)`` (``"log_alpha"``), ``t`` the sample's task; ``log_prob`` is detached
        (the loss only trains the temperatures)."""
        log_alpha = self._sample_log_alpha(task_id, log_prob.shape)
        log_prob = log_prob.detach()
        if self.alpha_loss_type == "alpha":
            return log_alpha.exp() * (-log_prob - self.target_entropy)
        return -log_alpha * (log_prob + self.target_entropy)

    # ------------------------------------------------------------------ loss
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        if self._version != 2:  # pragma: no cover - the constructor takes no value network
            raise RuntimeError(f"{type(self).__name__} implements SAC v2 (no value network)")
        task_id = self._task_ids(tensordict)
        with torch.no_grad():
            alpha = self._sample_log_alpha(task_id, tensordict.batch_size).exp()  # [*B]
        weights = self._maybe_get_priority_weight(tensordict)
        try:
            # SACLoss multiplies alpha with log-probs of shape [*B, 1] in the target and [*B] in the actor loss
            self._alpha_override = alpha.unsqueeze(-1)
            loss_qvalue, value_metadata = self.qvalue_v2_loss(tensordict)
            self._alpha_override = alpha
            loss_actor, metadata_actor = self.actor_loss(tensordict)
        finally:
            self._alpha_override = None
        log_prob = metadata_actor["log_prob"]
        loss_alpha = self._reduce_loss(self.alpha_loss(log_prob, task_id), tensordict=tensordict, weights=weights)
        tensordict.set(self.tensor_keys.priority, value_metadata["td_error"])
        if loss_actor.shape != loss_qvalue.shape:
            raise RuntimeError(f"Losses shape mismatch: {loss_actor.shape} and {loss_qvalue.shape}")
        out = TensorDict(
            {
                "loss_actor": loss_actor,
                "loss_qvalue": loss_qvalue,
                "loss_alpha": loss_alpha,
                "alpha": alpha.mean(),
                "entropy": -log_prob.detach().mean(),
            },
            batch_size=[],
        )
        self._clear_weakrefs(tensordict, out, "actor_network_params", "qvalue_network_params",
                             "target_actor_network_params", "target_qvalue_network_params")
        return out


__all__ = ["ALPHA_LOSSES", "MTSACLoss"]
