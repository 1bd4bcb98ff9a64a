"""Parkour: a Unitree Go1 on MTBench's 20 obstacle terrains + flat.

The terrain generator (``terrain``, ``terrains/``) is pure numpy and is imported here directly; the env side
(``ParkourEnv``, the settings) is imported on first attribute access, so that the terrain modules never import the
env's modules.
"""

from __future__ import annotations

import importlib
from typing import Any

from .terrain import Terrain, TerrainConfig, generate_terrain
from .terrains import TERRAIN_NAMES

_LAZY = {
    "ParkourEnv": ".env",
    "SETTINGS": ".settings",
    "make_parkour_env": ".settings",
}

__all__ = ["ParkourEnv", "SETTINGS", "TERRAIN_NAMES", "Terrain", "TerrainConfig", "generate_terrain",
           "make_parkour_env"]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(module, __name__), name)
