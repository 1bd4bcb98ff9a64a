"""Hooks of the training loops: adaptive learning rate, non-finite guard, checkpoints, logging, progress."""

from .adaptive_lr import AdaptiveLR
from .base import TrainerHook
from .checkpointer import Checkpointer
from .metrics_logger import MetricsLogger
from .nonfinite_guard import NonFiniteGuard
from .progress import ProgressHook

__all__ = ["AdaptiveLR", "Checkpointer", "MetricsLogger", "NonFiniteGuard", "ProgressHook", "TrainerHook"]
