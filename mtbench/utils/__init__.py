"""Small framework-level helpers shared by the envs and the trainer."""

from .cuda_graph import GraphedStage

__all__ = ["GraphedStage"]
