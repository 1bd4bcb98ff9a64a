"""Training loops and their parts (Hydra front door in examples/train.py, see docs/training.md).

``build_trainer(cfg, env=None, logger=None)`` builds an on-policy run (MT-PPO / MT-GRPO / MT-PQN) from the config; the
:class:`Trainer` itself takes plain components (env, policy, any TorchRL loss with a value estimator, optimizer,
hooks), so stock TorchRL losses train through it too.
"""

from .actor_critic import GaussianPolicyHead, make_actor, make_critic
from .builder import (
    add_observation_norm,
    build_env,
    build_gradient_method,
    build_hooks,
    build_loss,
    build_networks,
    build_optimizer,
    build_trainer,
)
from .config import LOSSES, check_config, resolve_device
from .hooks import (
    AdaptiveLR,
    Checkpointer,
    EpsilonSchedule,
    LinearLRDecay,
    MetricsLogger,
    NonFiniteGuard,
    ProgressHook,
    TrainerHook,
)
from .metrics import EpisodeStatsWindow
from .rollout import Rollout
from .skip_found_inf import RAdam, SkipOnFoundInf
from .stop import StopRequest
from .trainer import Trainer, observation_norm
from .update import MinibatchUpdate

__all__ = [
    "AdaptiveLR",
    "Checkpointer",
    "EpisodeStatsWindow",
    "EpsilonSchedule",
    "GaussianPolicyHead",
    "LOSSES",
    "LinearLRDecay",
    "MetricsLogger",
    "MinibatchUpdate",
    "NonFiniteGuard",
    "ProgressHook",
    "RAdam",
    "Rollout",
    "SkipOnFoundInf",
    "StopRequest",
    "Trainer",
    "TrainerHook",
    "add_observation_norm",
    "build_env",
    "build_gradient_method",
    "build_hooks",
    "build_loss",
    "build_networks",
    "build_optimizer",
    "build_trainer",
    "check_config",
    "make_actor",
    "make_critic",
    "observation_norm",
    "resolve_device",
]
