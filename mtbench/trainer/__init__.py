"""Training loops and their parts (Hydra front door in examples/train.py, see docs/training.md).

``build_trainer(cfg, env=None, logger=None)`` builds an on-policy run (MT-PPO / MT-GRPO / MT-PQN: :class:`Trainer`)
or an off-policy run (MT-SAC: :class:`OffPolicyTrainer`, docs/off_policy.md) from the config; the loops take plain
components (env, policy, any TorchRL loss, optimizer, hooks), so stock TorchRL losses train through them too.
"""

from .actor_critic import GaussianPolicyHead, make_actor, make_critic
from .builder import (
    add_action_clip,
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
from .exploration import ExplorationPolicy
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
from .loop import TrainingLoop
from .metrics import EpisodeStatsWindow
from .off_policy import OffPolicyTrainer
from .replay import make_replay_buffer
from .rollout import Rollout
from .sac_builder import add_observation_norm_keep_raw, build_sac_trainer
from .skip_found_inf import RAdam, SkipOnFoundInf
from .soft_actor_critic import SquashedNormal, make_qvalue, make_sac_actor
from .stop import StopRequest
from .trainer import Trainer, observation_norm
from .update import MinibatchUpdate

__all__ = [
    "AdaptiveLR",
    "Checkpointer",
    "EpisodeStatsWindow",
    "EpsilonSchedule",
    "ExplorationPolicy",
    "GaussianPolicyHead",
    "LOSSES",
    "LinearLRDecay",
    "MetricsLogger",
    "MinibatchUpdate",
    "NonFiniteGuard",
    "OffPolicyTrainer",
    "ProgressHook",
    "RAdam",
    "Rollout",
    "SkipOnFoundInf",
    "SquashedNormal",
    "StopRequest",
    "Trainer",
    "TrainerHook",
    "TrainingLoop",
    "add_action_clip",
    "add_observation_norm",
    "add_observation_norm_keep_raw",
    "build_env",
    "build_gradient_method",
    "build_hooks",
    "build_loss",
    "build_networks",
    "build_optimizer",
    "build_sac_trainer",
    "build_trainer",
    "check_config",
    "make_actor",
    "make_critic",
    "make_qvalue",
    "make_replay_buffer",
    "make_sac_actor",
    "observation_norm",
    "resolve_device",
]
