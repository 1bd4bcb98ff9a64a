"""Batched TorchRL environments on MuJoCo Warp."""

from .discrete_actions import DiscreteActions, bin_values
from .make import METAWORLD_SETS, is_parkour, make_env, metaworld_tasks, setting_names, split_envs
from .metaworld import MetaWorldEnv

__all__ = [
    "DiscreteActions",
    "METAWORLD_SETS",
    "MetaWorldEnv",
    "bin_values",
    "is_parkour",
    "make_env",
    "metaworld_tasks",
    "setting_names",
    "split_envs",
]
