"""MT-PPO / MT-GRPO training pipeline (Hydra front door in examples/train.py, see docs/training.md)."""

from .actor_critic import GaussianPolicyHead, make_actor, make_critic
from .metrics import EpisodeStatsWindow
from .trainer import LOSSES, Trainer, make_env_from_cfg, resolve_device

__all__ = [
    "EpisodeStatsWindow",
    "GaussianPolicyHead",
    "LOSSES",
    "Trainer",
    "make_actor",
    "make_critic",
    "make_env_from_cfg",
    "resolve_device",
]
