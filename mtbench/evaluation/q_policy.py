"""Evaluation policy of an MT-PQN checkpoint: the decomposed Q network behind the frozen observation normaliser."""

from __future__ import annotations

from typing import Any, Mapping

import torch
from omegaconf import OmegaConf
from tensordict import TensorDictBase
from torch import nn
from torchrl.data import Bounded, Categorical, MultiCategorical

from ..envs.discrete_actions import bin_values
from ..modules.q_network import make_q_network
from ..trainer.actor_critic import resolve_arch
from ..transforms import PerTaskObservationNorm
from .args import EvalArgumentError
from .policy import normalized_input, policy_task_sizes
from .task_slots import TaskSlots

Q_PREFIX = "value_network_params."


class EvalQPolicy(nn.Module):
    """``forward(td, deterministic)``: the greedy bang-off-bang action of the Q network (``deterministic=True``) or
    the epsilon-greedy one with the run's final rate ``epsilon`` (one draw per world, as in training). Returns the
    bins, or with ``values`` (``[A, bins]``: the continuous value of every bin) their values for a continuous-action
    env. The input tensordict is not modified.

    ``hold_steps`` > 1 (a run with ``loss.hold_observation``: ``loss.hold_period``, by default ``loss.horizon``) acts
    as that run's rollouts did: the greedy action is computed from the observation of every ``hold_steps``-th call
    (the first after :meth:`reset`) and kept for the calls in between; epsilon-greedy exploration still draws at
    every call."""

    def __init__(self, q_network: nn.Module, obs_norm: PerTaskObservationNorm | None, bins: int, epsilon: float,
                 values: torch.Tensor | None = None, hold_steps: int = 1, task_slots: TaskSlots | None = None) -> None:
        super().__init__()
        self.task_slots = task_slots
        if not (isinstance(hold_steps, int) and hold_steps >= 1):
            raise ValueError(f"hold_steps must be an integer >= 1; got {hold_steps!r}")
        self.q_network = q_network
        self.obs_norm = obs_norm
        if obs_norm is not None:
            obs_norm.freeze()
        self.bins = int(bins)
        self.epsilon = float(epsilon)
        self.hold_steps = hold_steps
        self.values: torch.Tensor | None
        self.register_buffer("values", values)
        self._calls = 0
        self._greedy: torch.Tensor | None = None
        self.eval()

    def reset(self) -> None:
        """Start a new hold at the next call (:func:`~mtbench.evaluation.episodes.run_episodes` calls it after every
        env reset)."""
        self._calls = 0
        self._greedy = None

    @torch.no_grad()
    def forward(self, td: TensorDictBase, deterministic: bool = False) -> torch.Tensor:
        if self._greedy is None or self._calls % self.hold_steps == 0:
            inp = normalized_input(td, self.obs_norm, self.task_slots)
            self._greedy = self.q_network(inp).get("action_value").argmax(-1)
        self._calls += 1
        action = self._greedy
        if not deterministic:
            explore = torch.rand(action.shape[:-1], device=action.device) < self.epsilon
            random = torch.randint(0, self.bins, action.shape, device=action.device)
            action = torch.where(explore[..., None], random, action)
        if self.values is None:
            return action
        return self.values.expand(*action.shape, self.bins).gather(-1, action.unsqueeze(-1)).squeeze(-1)


def load_q_policy(state: Mapping[str, Any], env: Any, device: torch.device,
                  task_slots: TaskSlots | None = None) -> EvalQPolicy:
    """Q network (``make_q_network`` with the run's arch, critic role) and observation normaliser of a ``loss=pqn``
    checkpoint, for ``env`` (the run's env config: continuous actions unless ``env.overrides.actions=discrete``)."""
    cfg = OmegaConf.create(state["config"])
    bins = int(cfg.loss.bins_per_dim)
    spec = env.action_spec
    if isinstance(spec, Categorical) and not isinstance(spec, MultiCategorical):
        if int(spec.n) != bins:
            raise EvalArgumentError(f"the env's discrete actions have {spec.n} bins per dimension, the checkpoint's "
                                    f"Q network {bins} (loss.bins_per_dim={bins}); evaluate on an env with {bins} "
                                    f"bins or with continuous actions")
    elif not isinstance(spec, Bounded):
        raise EvalArgumentError(f"a PQN checkpoint needs an env with a Bounded (continuous) or Categorical action "
                                f"spec; got {type(spec).__name__}")
    num_tasks, obs_dim, descriptions = policy_task_sizes(env, task_slots)
    name, kwargs = resolve_arch(cfg.get("arch"), "critic")
    q_network = make_q_network(
        name, obs_dim=obs_dim, action_dim=int(spec.shape[-1]), bins=bins, num_tasks=num_tasks,
        task_descriptions=descriptions, **kwargs,
    ).to(device)
    weights = {k[len(Q_PREFIX):]: v for k, v in state["loss"].items() if k.startswith(Q_PREFIX)}
    # the loss keeps every buffer of the network, also the non-persistent ones (e.g. MOORE's task one-hots) that
    # the network's own state_dict leaves out
    for prefix, sub in q_network.named_modules():
        for buffer in getattr(sub, "_non_persistent_buffers_set", ()):
            weights.pop(f"{prefix}.{buffer}" if prefix else buffer, None)
    try:
        q_network.load_state_dict(weights, strict=True)
    except RuntimeError as err:
        raise EvalArgumentError(f"the checkpoint's Q network does not fit the rebuilt one (arch={name!r}): "
                                f"{err}") from None
    obs_norm = None
    norm_state = state.get("obs_norm")
    if cfg.loss.get("normalize_input", False) and norm_state is not None:
        obs_norm = PerTaskObservationNorm(num_tasks, state_dim=int(norm_state["stats.mean"].shape[-1]), device=device)
        obs_norm.load_state_dict(norm_state)
    values = None
    if isinstance(spec, Bounded):  # the bins' values per dimension: DiscreteActions' map over the env's bounds
        action_dim = int(spec.shape[-1])
        low, high = spec.low.reshape(-1, action_dim)[0, :, None], spec.high.reshape(-1, action_dim)[0, :, None]
        values = low + (high - low) * bin_values(bins, 0.0, 1.0).to(low)
    hold_steps = int(cfg.loss.get("hold_period") or cfg.loss.horizon) if cfg.loss.get("hold_observation", False) else 1
    policy = EvalQPolicy(q_network, obs_norm, bins, float(cfg.loss.end_epsilon), values, hold_steps, task_slots)
    return policy.to(device)


__all__ = ["EvalQPolicy", "Q_PREFIX", "load_q_policy"]
