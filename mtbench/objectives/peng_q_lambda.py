"""Peng's Q(lambda) targets as a TorchRL value estimator (MT-PQN; purejaxql ``pqn_gymnax.py::_get_target``)."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModule
from tensordict.utils import NestedKey
from torchrl.objectives.value import ValueEstimatorBase

from ..modules.q_network import greedy_value
from ..transforms.running_mean_std import PerTaskRunningMeanStd
from .per_task_gae import last_next_inputs, rollout_time_dim, task_ids


def peng_q_lambda(
    reward: torch.Tensor,
    bootstrap: torch.Tensor,
    done: torch.Tensor,
    terminated: torch.Tensor,
    gamma: float,
    lmbda: float,
    time_dim: int = -2,
) -> torch.Tensor:
    """Peng's Q(lambda) returns, backwards over ``time_dim`` (``T`` steps):

    ``G_{T-1} = r_{T-1} + gamma (1 - term_{T-1}) boot_{T-1}``,
    ``G_t = r_t + gamma (1 - term_t) [lambda_t G_{t+1} + (1 - lambda_t) boot_t]`` with ``lambda_t = lambda (1 -
    done_t)``.

    Args:
        reward: ``r_t`` of the transition at ``t``.
        bootstrap: ``boot_t``, the greedy value ``max_a Q`` of the state the transition at ``t`` leads to (any value
            where ``terminated``).
        done: the transition at ``t`` ends its episode (terminated or truncated): ``G_{t+1}`` belongs to another
            episode and is not used.
        terminated: the episode ended in a terminal state: no bootstrap.
        gamma, lmbda: discount and trace parameter (lambda = 0: one-step targets; 1: Monte-Carlo returns
            bootstrapped at the end of the window and at truncations).

    All four tensors share a shape (e.g. ``[N, T, 1]``). The recursion is the purejaxql one, where the lambda
    term is masked at episode ends (MTBench's ``pqn_agent.py`` masks only the ``(1 - lambda)`` term, so its
    targets leak the next episode's return into the last step of an episode).
    """
    shapes = {tuple(t.shape) for t in (reward, bootstrap, done, terminated)}
    if len(shapes) != 1:
        raise ValueError(f"reward, bootstrap, done and terminated must have the same shape; got "
                         f"{[tuple(t.shape) for t in (reward, bootstrap, done, terminated)]}")
    r = reward.movedim(time_dim, 0)
    boot = bootstrap.to(r.dtype).movedim(time_dim, 0)
    discount = gamma * (~terminated.to(torch.bool)).to(r.dtype).movedim(time_dim, 0)
    trace = lmbda * (~done.to(torch.bool)).to(r.dtype).movedim(time_dim, 0)
    out = torch.empty_like(r)
    running = r[-1] + discount[-1] * boot[-1]
    out[-1] = running
    for t in range(r.shape[0] - 2, -1, -1):
        running = r[t] + discount[t] * (trace[t] * running + (1.0 - trace[t]) * boot[t])
        out[t] = running
    return out.movedim(0, time_dim)


class PengQLambda(ValueEstimatorBase):
    """Peng's Q(lambda) targets of a ``[*B, T]`` native-autoreset rollout for a decomposed Q network.

    ``estimator(rollout)`` (time last, under ``no_grad``, no host synchronisation) evaluates the Q network on
    ``observation[..., t]`` for every ``t`` and on the last ``("next", observation)`` (rows done at the last step
    have NaN next observations under TorchRL's native autoreset: they are zeroed and their value unused), takes
    the greedy values ``V(s) = mean_j max_b Q_j(s, b)`` and writes ``value_target`` = :func:`peng_q_lambda` with

    * ``boot_t = V(s_{t+1}) = V(observation[..., t + 1])`` (``V`` of the last next observation at ``t = T - 1``):
      the end of the window is bootstrapped;
    * on a truncated step (time limit) the true next observation is lost (the env has already reset that world),
      so ``boot_t = V(s_t)``, the value of the step's own state: the bootstrap of TorchRL's
      ``GAE(auto_reset_env=True)`` (rl_games' ``value_bootstrap``); the trace is cut there;
    * on a terminated step (or a done step that is not truncated) there is no bootstrap.

    With ``normalize_value`` the Q network predicts per-task *normalised* values (as MT-PPO's critic does with
    :class:`~mtbench.objectives.PerTaskGAE`): the greedy values are de-normalised with the task's running statistics
    (:attr:`value_norm`), the targets are computed in the reward's scale, the statistics are updated with them, and
    ``value_target`` is written normalised with the updated statistics. A positive affine map per task leaves each
    task's greedy actions unchanged; what changes is the weight of each task in the regression (without it the tasks
    whose returns are largest dominate the loss). The statistics are buffers of this estimator, hence part of the
    owning loss's ``state_dict`` (``_value_estimator.value_norm.*``).

    Args:
        gamma: discount (0.99).
        lmbda: Peng's lambda (0.5).
        value_network: the Q network (writes ``action_value [..., A, bins]``), e.g.
            :func:`~mtbench.modules.make_q_network`.
        num_tasks: K (needed with ``normalize_value``).
        normalize_value: per-task value normalisation (MTBench's PQN: off).
        value_norm_eps: variance epsilon of the statistics (rl_games: 1e-5).
        device: device of the statistics.
    """

    @dataclass
    class _AcceptedKeys:
        """The keys of :class:`ValueEstimatorBase` (repeated: TorchRL's ``set_keys`` accepts only a class's own
        fields; ``advantage`` and ``value`` are not written) plus ``truncated`` (``("next", truncated)``: bootstrap
        on time limits), ``action_value`` (the Q network's ``[..., A, bins]`` output) and ``task_id`` (the per-task
        statistics of ``normalize_value``)."""

        advantage: NestedKey = "advantage"
        value_target: NestedKey = "value_target"
        value: NestedKey = "state_value"
        reward: NestedKey = "reward"
        done: NestedKey = "done"
        terminated: NestedKey = "terminated"
        steps_to_next_obs: NestedKey = "steps_to_next_obs"
        sample_log_prob: NestedKey = "action_log_prob"
        truncated: NestedKey = "truncated"
        action_value: NestedKey = "action_value"
        task_id: NestedKey = "task_id"

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys

    def __init__(
        self,
        *,
        gamma: float,
        lmbda: float,
        value_network: TensorDictModule,
        num_tasks: int | None = None,
        normalize_value: bool = False,
        value_norm_eps: float = 1e-5,
        device: torch.device | str | None = None,
    ) -> None:
        if value_network is None:
            raise ValueError("PengQLambda needs the Q network as value_network")
        if normalize_value and not (isinstance(num_tasks, int) and num_tasks >= 1):
            raise ValueError(f"normalize_value=True needs num_tasks (an integer >= 1); got {num_tasks!r}")
        if not 0.0 <= float(lmbda) <= 1.0:
            raise ValueError(f"lmbda must be in [0, 1]; got {lmbda}")
        if not 0.0 < float(gamma) <= 1.0:
            raise ValueError(f"gamma must be in (0, 1]; got {gamma}")
        super().__init__(value_network=value_network, device=device)
        self.gamma = float(gamma)
        self.lmbda = float(lmbda)
        self.value_norm: PerTaskRunningMeanStd | None = (
            PerTaskRunningMeanStd(int(num_tasks), 1, eps=value_norm_eps, device=device) if normalize_value else None
        )

    @property
    def in_keys(self) -> list[NestedKey]:
        k = self.tensor_keys
        keys = list(self.value_network.in_keys)
        keys += [("next", k.reward), ("next", k.done), ("next", k.terminated), ("next", k.truncated)]
        keys += [("next", key) for key in self.value_network.in_keys]
        if self.value_norm is not None:
            keys.append(k.task_id)
        return list(dict.fromkeys(keys))

    @property
    def out_keys(self) -> list[NestedKey]:
        return [self.tensor_keys.value_target]

    def _greedy(self, td: TensorDictBase, params: TensorDictBase | None) -> torch.Tensor:
        if params is not None:
            with params.to_module(self.value_network, preserve_module_state=False):
                action_value = self.value_network(td).get(self.tensor_keys.action_value)
        else:
            action_value = self.value_network(td).get(self.tensor_keys.action_value)
        return greedy_value(action_value).unsqueeze(-1)

    @torch.no_grad()
    def forward(
        self,
        tensordict: TensorDictBase,
        *,
        params: TensorDictBase | None = None,
        target_params: TensorDictBase | None = None,
        time_dim: int | None = None,
    ) -> TensorDictBase:
        """Write ``value_target [*B, T, 1]`` into ``tensordict`` (returned). ``params``: functional Q-network
        parameters (what a TorchRL loss passes); ``target_params`` is accepted for API compatibility and unused
        (PQN has no target network)."""
        tdim = rollout_time_dim(self, tensordict, time_dim)
        keys = self.tensor_keys
        in_keys = list(self.value_network.in_keys)
        values = self._greedy(tensordict.select(*in_keys), params)  # V(s_t), [*B, T, 1]
        next_td = tensordict.get("next")
        done = next_td.get(keys.done)
        last = last_next_inputs(tensordict, in_keys, keys.done, tdim)  # rows done at T-1: value unused
        last_value = self._greedy(last, params).unsqueeze(tdim)
        index = (slice(None),) * tdim + (slice(1, None),)
        next_values = torch.cat([values[index], last_value], dim=tdim)
        truncated = next_td.get(keys.truncated, torch.zeros_like(done))
        terminated = next_td.get(keys.terminated)
        no_bootstrap = terminated | (done & ~truncated)
        if self.value_norm is not None:  # the network's values are per-task normalised: back to the reward's scale
            task_id = task_ids(tensordict, keys.task_id)
            values = self.value_norm.denormalize(values, task_id)
            next_values = self.value_norm.denormalize(next_values, task_id)
        bootstrap = torch.where(truncated & ~terminated, values, next_values)
        target = peng_q_lambda(next_td.get(keys.reward), bootstrap, done, no_bootstrap, self.gamma, self.lmbda,
                               time_dim=tdim)
        if self.value_norm is not None:
            self.value_norm.update(target, task_id)
            target = self.value_norm.normalize(target, task_id)
        tensordict.set(keys.value_target, target)
        return tensordict


__all__ = ["PengQLambda", "peng_q_lambda"]
