"""Small framework-level helpers shared by the envs and the trainer."""

from . import distributed
from .cuda_graph import GraphedStage

__all__ = ["GraphedStage", "distributed"]
