"""The MT-PQN pieces of a run (``loss=pqn``): the discrete-action env, the decomposed Q network with its
epsilon-greedy policy, the loss with Peng's Q(lambda), RAdam and the schedule hooks. ``build_trainer`` calls them;
the loop is the on-policy :class:`~mtbench.trainer.Trainer` (rollout, ``loss.value_estimator``, minibatches)."""

from __future__ import annotations

import numbers
from typing import Any, Mapping

import torch
from omegaconf import DictConfig
from tensordict.nn import TensorDictModule, TensorDictSequential
from tensordict.utils import NestedKey
from torchrl.data import Bounded, Categorical, MultiCategorical
from torchrl.envs import EnvBase, TransformedEnv

from ..envs.discrete_actions import DiscreteActions
from ..modules.q_network import make_q_network, make_q_policy
from ..objectives.pqn import LOSS_FUNCTIONS, MTPQNLoss
from .actor_critic import resolve_arch
from .env_factory import network_sizes
from .hooks import EpsilonSchedule, LinearLRDecay, TrainerHook
from .hooks.schedules import EPSILON_CLOCKS
from .rollout import base_env
from .skip_found_inf import RAdam


def _number(lc: Mapping[str, Any], key: str, low: float, high: float, *, low_open: bool = False) -> float:
    value = lc.get(key)
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    ok = ok and (low < value if low_open else low <= value) and value <= high
    if not ok:
        interval = f"{'(' if low_open else '['}{low}, {high}]"
        raise ValueError(f"loss.{key} must be a number in {interval}; got {value!r}")
    return float(value)


def check_pqn_config(lc: Mapping[str, Any]) -> None:
    """Validate the ``loss=pqn`` values (one ``ValueError`` naming the parameter and its valid range)."""
    bins = lc.get("bins_per_dim")
    if not (isinstance(bins, int) and not isinstance(bins, bool) and bins >= 2):
        raise ValueError(f"loss.bins_per_dim must be an integer >= 2 (3 = bang-off-bang); got {bins!r}")
    _number(lc, "gamma", 0.0, 1.0, low_open=True)
    _number(lc, "lmbda", 0.0, 1.0)
    _number(lc, "lr", 0.0, float("inf"), low_open=True)
    start = _number(lc, "start_epsilon", 0.0, 1.0)
    end = _number(lc, "end_epsilon", 0.0, 1.0)
    if end > start:
        raise ValueError(f"loss.end_epsilon={end} must be <= loss.start_epsilon={start}")
    _number(lc, "exploration_fraction", 0.0, 1.0, low_open=True)
    if lc.get("epsilon_clock", "frames") not in EPSILON_CLOCKS:
        raise ValueError(f"unknown loss.epsilon_clock {lc.get('epsilon_clock')!r}; valid choices: "
                         f"{list(EPSILON_CLOCKS)}")
    if not isinstance(lc.get("hold_observation", False), bool):
        raise ValueError(f"loss.hold_observation must be true or false; got {lc.get('hold_observation')!r}")
    period, horizon = lc.get("hold_period"), lc.get("horizon")
    if period is not None and not (isinstance(period, int) and not isinstance(period, bool)
                                   and isinstance(horizon, int) and 1 <= period <= horizon):
        raise ValueError(f"loss.hold_period must be an integer in [1, loss.horizon={horizon}] or null (the whole "
                         f"rollout); got {period!r}")
    if not isinstance(lc.get("normalize_value", False), bool):
        raise ValueError(f"loss.normalize_value must be true or false; got {lc.get('normalize_value')!r}")
    if not isinstance(lc.get("anneal_lr"), bool):
        raise ValueError(f"loss.anneal_lr must be true or false; got {lc.get('anneal_lr')!r}")
    if lc.get("loss_function") not in LOSS_FUNCTIONS:
        raise ValueError(f"unknown loss.loss_function {lc.get('loss_function')!r}; valid choices: "
                         f"{list(LOSS_FUNCTIONS)}")


def discrete_action_env(env: EnvBase, bins: int) -> EnvBase:
    """``env`` with :class:`~mtbench.envs.DiscreteActions` (``bins`` per dimension) unless its actions already are
    ``bins`` categorical values (``env.overrides.actions=discrete``); a continuous env must have a ``Bounded``
    action spec."""
    spec = env.action_spec
    if isinstance(spec, Categorical) and not isinstance(spec, MultiCategorical):
        if int(spec.n) != int(bins):
            raise ValueError(f"the env's discrete actions have {spec.n} bins, loss.bins_per_dim={bins}; make them "
                             "agree (env.overrides.bins)")
        return env
    if not isinstance(spec, Bounded):
        raise ValueError(f"loss=pqn needs a Bounded (continuous) or Categorical action spec; got "
                         f"{type(spec).__name__}")
    discrete = TransformedEnv(env, DiscreteActions(bins))
    if base_env(env).__dict__.get("_torchrl_native_autoreset"):  # TorchRL reads it from the instance
        discrete.__dict__["_torchrl_native_autoreset"] = True
    return discrete


def make_pqn_policy(cfg: DictConfig, env: EnvBase, device: torch.device) -> TensorDictSequential:
    """Decomposed Q network of the ``arch`` preset (its ``critic`` role: MTBench's Q network is its critic) over
    the env's discrete actions, behind stock ``QValueModule`` and ``EGreedyModule`` (``eps`` = start epsilon)."""
    spec, n = env.action_spec, network_sizes(env)
    name, kwargs = resolve_arch(cfg.get("arch"), "critic")
    q_network = make_q_network(name, obs_dim=n.obs_dim, action_dim=n.action_dim, bins=int(spec.n),
                               num_tasks=n.num_tasks, task_descriptions=n.task_descriptions, **kwargs)
    lc = cfg.loss
    policy = make_q_policy(q_network, spec, eps_init=float(lc.start_epsilon), eps_end=float(lc.end_epsilon))
    return policy.to(device)


def q_network(policy: TensorDictSequential) -> TensorDictModule:
    """The Q network of a :func:`make_pqn_policy` policy (its first module)."""
    return policy[0]


def build_pqn_loss(loss_cfg: Mapping[str, Any], policy: TensorDictSequential, num_tasks: int,
                   device: torch.device) -> MTPQNLoss:
    """``MTPQNLoss`` (Peng's Q(lambda) estimator; per-task value normalisation with ``loss.normalize_value``) on
    the policy's Q network."""
    return MTPQNLoss(q_network(policy), gamma=float(loss_cfg["gamma"]), lmbda=float(loss_cfg["lmbda"]),
                     loss_function=str(loss_cfg["loss_function"]), num_tasks=num_tasks,
                     normalize_value=bool(loss_cfg.get("normalize_value", False))).to(device)


def build_radam(loss: MTPQNLoss, loss_cfg: Mapping[str, Any], device: torch.device) -> RAdam:
    """RAdam (``loss.lr``, betas 0.9/0.999, eps 1e-8: MTBench's ``critic_optimizer``) over the Q network, with a
    tensor learning rate on the device; ``capturable`` on CUDA (state on the device: no host sync per step). It
    honours ``found_inf`` (:class:`~mtbench.trainer.skip_found_inf.SkipOnFoundInf`), so the non-finite guard can
    skip an update."""
    params = [p for p in loss.parameters() if p.requires_grad]
    lr = torch.tensor(float(loss_cfg["lr"]), device=device)
    return RAdam(params, lr=lr, betas=(0.9, 0.999), eps=1e-8, capturable=device.type == "cuda")


def pqn_hold_keys(loss_cfg: Mapping[str, Any], policy: TensorDictSequential) -> list[NestedKey]:
    """The rollout entries held at their first-step value (``loss.hold_observation``: the Q network's inputs, as
    MTBench's rollout loop, which acts on and stores the rollout's first observation at every step), else none."""
    return list(q_network(policy).in_keys) if loss_cfg.get("hold_observation", False) else []


def pqn_hooks(loss_cfg: Mapping[str, Any]) -> list[TrainerHook]:
    """The epsilon schedule (``loss.epsilon_clock``) and, with ``loss.anneal_lr``, the linear learning-rate
    decay."""
    hooks: list[TrainerHook] = [EpsilonSchedule(float(loss_cfg["start_epsilon"]), float(loss_cfg["end_epsilon"]),
                                                float(loss_cfg["exploration_fraction"]),
                                                str(loss_cfg.get("epsilon_clock", "frames")))]
    if loss_cfg.get("anneal_lr", True):
        hooks.append(LinearLRDecay(float(loss_cfg["lr"])))
    return hooks


__all__ = ["build_pqn_loss", "build_radam", "check_pqn_config", "discrete_action_env", "make_pqn_policy",
           "pqn_hold_keys", "pqn_hooks", "q_network"]
