"""Parkour: a Unitree Go1 on MTBench's 20 obstacle terrains + flat (MuJoCo Warp).

The terrain generator (``terrain``, ``terrains/``) is pure numpy and imports nothing heavy; the env side
(``ParkourEnv`` and its helpers) is imported lazily on first attribute access so that importing the terrain
package does not pull in MuJoCo Warp.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "ParkourEnv": ".env",
    "SETTINGS": ".settings",
    "make_parkour_env": ".settings",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(module, __name__), name)
