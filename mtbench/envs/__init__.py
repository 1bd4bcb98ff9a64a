"""Batched TorchRL environments on MuJoCo Warp."""

from .make import METAWORLD_SETS, make_env, setting_names, split_envs
from .metaworld import MetaWorldEnv

__all__ = ["METAWORLD_SETS", "MetaWorldEnv", "make_env", "setting_names", "split_envs"]
