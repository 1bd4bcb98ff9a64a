"""Hooks of the training loops: adaptive learning rate, non-finite guard, checkpoints, logging, progress, the
epsilon and learning-rate schedules of MT-PQN."""

from .adaptive_lr import AdaptiveLR
from .base import TrainerHook
from .checkpointer import Checkpointer
from .metrics_logger import MetricsLogger
from .nonfinite_guard import NonFiniteGuard
from .progress import ProgressHook
from .schedules import EpsilonSchedule, LinearLRDecay

__all__ = ["AdaptiveLR", "Checkpointer", "EpsilonSchedule", "LinearLRDecay", "MetricsLogger", "NonFiniteGuard",
           "ProgressHook", "TrainerHook"]
