"""TorchRL transforms and normalisers for multi-task training."""

from .observation_norm import PerTaskObservationNorm
from .running_mean_std import PerTaskRunningMeanStd

__all__ = ["PerTaskObservationNorm", "PerTaskRunningMeanStd"]
