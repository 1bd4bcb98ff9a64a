"""MT-PQN loss (MTBench ``pqn_agent.py::MTPQNAgent``): a decomposed Q network regressed onto Peng's Q(lambda)
targets of the on-policy rollout; no replay buffer, no target network.

* the Q network outputs per-dimension utilities ``[..., A, bins]`` over bang-off-bang actions;
  ``Q(s, a) = mean_j Q_j(s, a_j)`` (:func:`~mtbench.modules.decomposed_q_value`);
* targets: the loss's value estimator, by default :class:`~mtbench.objectives.peng_q_lambda.PengQLambda`
  (gamma 0.99, lambda 0.5), computed once per rollout with the parameters that collected it;
* loss: ``(Q(s_t, a_t) - G_t)^2`` (MTBench's ``nn.MSELoss``), ``loss_function`` ``l2`` / ``l1`` / ``smooth_l1``.

Use it like any TorchRL loss: ``loss.value_estimator(rollout)`` on the collected ``[N, T]`` rollout, then
``loss(minibatch)`` on flat minibatches of it. ``reduction="none"`` returns the per-sample ``loss_qvalue`` (shape =
batch shape) for the gradient-manipulation wrappers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import TensorDictModule, TensorDictParams
from tensordict.utils import NestedKey
from torchrl.objectives import LossModule
from torchrl.objectives.utils import distance_loss
from torchrl.objectives.value import ValueEstimatorBase

from ..modules.q_network import decomposed_q_value
from .peng_q_lambda import PengQLambda

LOSS_FUNCTIONS = ("l2", "l1", "smooth_l1")
_VALID_REDUCTIONS = ("mean", "sum", "none")


class MTPQNLoss(LossModule):
    """Parallel Q-learning loss for a decomposed Q network (MT-PQN).

    Expects the minibatch to hold the observation entries of the Q network, the integer ``action [..., A]`` and the
    ``value_target`` written by the value estimator: run ``loss.value_estimator(rollout)`` on the collected
    ``[N, T]`` rollout first. Output: ``loss_qvalue`` and the detached metrics ``q_value`` (mean ``Q(s, a)``),
    ``target_value`` (mean target) and ``td_error`` (mean ``|Q(s, a) - G|``).

    Every key the loss or its value estimator reads is declared in :class:`_AcceptedKeys` and can be renamed with
    ``loss.set_keys(...)``; the estimator's keys follow.

    Args:
        value_network: the Q network, a ``TensorDictModule`` writing ``action_value [..., A, bins]`` (e.g.
            :func:`~mtbench.modules.make_q_network`).
        gamma, lmbda: Peng's Q(lambda) parameters of the default estimator (0.99, 0.5).
        loss_function: ``"l2"`` (MTBench: MSE), ``"l1"`` or ``"smooth_l1"``.
        reduction: ``"mean"`` (default), ``"sum"`` or ``"none"`` (per-sample ``loss_qvalue``).
        num_tasks, normalize_value: per-task value normalisation of the default estimator (off, as MTBench's PQN):
            the Q network predicts per-task normalised values, the targets are normalised with the task's running
            statistics (:class:`~mtbench.objectives.peng_q_lambda.PengQLambda`); ``q_value``, ``target_value`` and
            ``td_error`` are then in that normalised scale.
    """

    @dataclass
    class _AcceptedKeys:
        """Keys read by the loss and forwarded to its value estimator.

        Attributes:
            action: the integer action ``[..., A]`` (bins).
            action_value: the Q network's output ``[..., A, bins]``.
            value_target: Peng's Q(lambda) target written by the value estimator.
            reward, done, terminated, truncated: ``("next", ...)`` entries the estimator reads.
            task_id: per-sample task index (int64, batch-shaped; read by the gradient-manipulation wrappers).
        """

        action: NestedKey = "action"
        action_value: NestedKey = "action_value"
        value_target: NestedKey = "value_target"
        reward: NestedKey = "reward"
        done: NestedKey = "done"
        terminated: NestedKey = "terminated"
        truncated: NestedKey = "truncated"
        task_id: NestedKey = "task_id"

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys
    value_network: TensorDictModule
    value_network_params: TensorDictParams
    target_value_network_params: TensorDictParams

    def __init__(
        self,
        value_network: TensorDictModule,
        *,
        gamma: float = 0.99,
        lmbda: float = 0.5,
        loss_function: str = "l2",
        reduction: str = "mean",
        num_tasks: int | None = None,
        normalize_value: bool = False,
    ) -> None:
        if reduction not in _VALID_REDUCTIONS:
            raise ValueError(f"unknown reduction {reduction!r}; valid choices: {list(_VALID_REDUCTIONS)}")
        if loss_function not in LOSS_FUNCTIONS:
            raise ValueError(f"unknown loss_function {loss_function!r}; valid choices: {list(LOSS_FUNCTIONS)}")
        if not isinstance(value_network, TensorDictModule):
            raise TypeError(f"value_network must be a TensorDictModule writing the action values; got "
                            f"{type(value_network).__name__}")
        super().__init__()
        self._in_keys: list[NestedKey] | None = None
        self.convert_to_functional(value_network, "value_network", create_target_params=False)
        self.gamma = float(gamma)
        self.lmbda = float(lmbda)
        self.loss_function = loss_function
        self.reduction = reduction
        self.num_tasks = num_tasks
        self.normalize_value = bool(normalize_value)
        self.tensor_keys.action_value = value_network.out_keys[0]
        self.make_value_estimator()

    # ------------------------------------------------------------------ keys and value estimator
    def _set_in_keys(self) -> None:
        k = self.tensor_keys
        self._in_keys = list(dict.fromkeys([*self.value_network.in_keys, k.action, k.value_target, k.task_id]))

    @property
    def in_keys(self) -> list[NestedKey]:
        if self._in_keys is None:
            self._set_in_keys()
        return self._in_keys

    @property
    def out_keys(self) -> list[NestedKey]:
        return ["loss_qvalue", "q_value", "target_value", "td_error"]

    def _forward_value_estimator_keys(self, **kwargs: Any) -> None:
        """Give the value estimator every key it declares under the same name."""
        estimator = getattr(self, "_value_estimator", None)
        if estimator is not None:
            names = estimator._AcceptedKeys.__dataclass_fields__
            estimator.set_keys(**{n: getattr(self.tensor_keys, n) for n in names if hasattr(self.tensor_keys, n)})
        self._set_in_keys()

    def make_value_estimator(self, value_type: Any = None, **hyperparams: Any) -> MTPQNLoss:
        """``None``: :class:`~mtbench.objectives.peng_q_lambda.PengQLambda` (``hyperparams`` override ``gamma`` /
        ``lmbda`` / ``num_tasks`` / ``normalize_value``); a ``ValueEstimatorBase`` instance or subclass is used as
        TorchRL does. The loss's keys are forwarded to the estimator."""
        if value_type is None:
            kwargs: dict[str, Any] = dict(gamma=self.gamma, lmbda=self.lmbda, num_tasks=self.num_tasks,
                                          normalize_value=self.normalize_value)
            kwargs.update(hyperparams)
            self._value_estimator = PengQLambda(value_network=self.value_network, **kwargs)
            self.value_type = PengQLambda
        elif isinstance(value_type, ValueEstimatorBase) or (
            isinstance(value_type, type) and issubclass(value_type, ValueEstimatorBase)
        ):
            super().make_value_estimator(value_type, **hyperparams)
        else:
            raise ValueError(f"MTPQNLoss.make_value_estimator takes None (Peng's Q(lambda)) or a ValueEstimatorBase "
                             f"instance or subclass; got {value_type!r}")
        self._forward_value_estimator_keys()
        return self

    # ------------------------------------------------------------------ loss
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        keys = self.tensor_keys
        target = tensordict.get(keys.value_target, None)
        if target is None:
            raise KeyError(f"{type(self).__name__}: '{keys.value_target}' missing; run loss.value_estimator(rollout) "
                           "on the collected [N, T] rollout first")
        action = tensordict.get(keys.action, None)
        if action is None or action.is_floating_point():
            raise KeyError(f"{type(self).__name__}: needs the integer action bins '{keys.action}' [..., A] (a "
                           "discrete-action env, e.g. make_env(..., actions='discrete'))")
        td = tensordict.select(*self.value_network.in_keys, strict=False)
        with self.value_network_params.to_module(self.value_network, preserve_module_state=False):
            action_value = self.value_network(td).get(keys.action_value)
        q_value = decomposed_q_value(action_value, action)
        target = target.reshape(q_value.shape).to(q_value.dtype)
        loss = distance_loss(q_value, target, self.loss_function)
        with torch.no_grad():
            metrics = {"q_value": q_value.mean(), "target_value": target.mean(),
                       "td_error": (q_value - target).abs().mean()}
        result = TensorDict({"loss_qvalue": self._reduce_loss(loss, tensordict)}, batch_size=[])
        for name, value in metrics.items():
            result.set(name, value.detach())
        self._clear_weakrefs(tensordict, "value_network_params")
        return result


__all__ = ["LOSS_FUNCTIONS", "MTPQNLoss"]
