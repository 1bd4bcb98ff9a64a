"""Batched TorchRL environments on MuJoCo Warp."""

from .make import METAWORLD_SETS, is_parkour, make_env, setting_names, split_envs
from .metaworld import MetaWorldEnv

__all__ = ["METAWORLD_SETS", "MetaWorldEnv", "is_parkour", "make_env", "setting_names", "split_envs"]
