"""The Parkour terrains: one module per terrain, discovered here and ordered by MTBench's task id.

Every public module of this package is one terrain. It defines

* ``TASK_ID``: the terrain's index in MTBench (``TERRAIN_FUNCTIONS`` order; also its one-hot slot),
* ``DIFFICULTY_RANGE``: the original's ``DIFFICULTY_SCALING`` entry ``(min, max)`` before the -0.2 shift, or
  ``None`` when the terrain is drawn with the raw row difficulty,
* ``generate(rng, d, tile) -> goals``: draws the obstacles into ``tile.heights`` (metres) with ``d`` the effective
  difficulty and returns the 8 waypoints ``[8, 2]`` in tile cells (x along, y across).

The module's first docstring line is the terrain's one-line description.
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass
from types import ModuleType
from typing import Callable

import numpy as np

from ._difficulty import EASIER_OFFSET, scale_difficulty, shifted_range
from ._tile import NUM_GOALS, PIT_HEIGHT, SPAWN_LENGTH, Tile

GenerateFn = Callable[[np.random.RandomState, float, Tile], np.ndarray]


@dataclass(frozen=True)
class TerrainSpec:
    """One terrain: its name (= module name), task id, difficulty range and drawing function."""

    name: str
    task_id: int
    difficulty_range: tuple[float, float] | None
    generate: GenerateFn
    summary: str

    def effective_difficulty(self, d: float) -> float:
        """The difficulty this terrain is drawn with at row difficulty ``d`` (see ``_difficulty``)."""
        return scale_difficulty(d, self.difficulty_range)


def _spec(module: ModuleType) -> TerrainSpec:
    name = module.__name__.rsplit(".", 1)[-1]
    for attr in ("TASK_ID", "DIFFICULTY_RANGE", "generate"):
        if not hasattr(module, attr):
            raise RuntimeError(f"terrain module {module.__name__} does not define {attr}")
    summary = (module.__doc__ or "").strip().splitlines()[0] if module.__doc__ else ""
    return TerrainSpec(name, int(module.TASK_ID), module.DIFFICULTY_RANGE, module.generate, summary)


def _discover() -> dict[str, TerrainSpec]:
    specs = [_spec(importlib.import_module(f"{__name__}.{info.name}"))
             for info in pkgutil.iter_modules(__path__) if not info.name.startswith("_")]
    specs.sort(key=lambda s: s.task_id)
    ids = [s.task_id for s in specs]
    if ids != list(range(len(specs))):
        raise RuntimeError(f"terrain task ids must be 0..{len(specs) - 1} without repeats, got {ids}")
    return {s.name: s for s in specs}


TERRAINS: dict[str, TerrainSpec] = _discover()
"""Every terrain by name, in task-id order."""

TERRAIN_NAMES: tuple[str, ...] = tuple(TERRAINS)
"""The canonical MTBench task list (index = task id = one-hot slot): 20 obstacle terrains, then flat."""


def terrain_spec(name: str) -> TerrainSpec:
    """The terrain called ``name``; raises ``ValueError`` naming the valid choices otherwise."""
    if name not in TERRAINS:
        raise ValueError(f"unknown parkour terrain {name!r}; valid choices: {list(TERRAIN_NAMES)}")
    return TERRAINS[name]


__all__ = [
    "EASIER_OFFSET", "NUM_GOALS", "PIT_HEIGHT", "SPAWN_LENGTH", "TERRAINS", "TERRAIN_NAMES", "TerrainSpec", "Tile",
    "scale_difficulty", "shifted_range", "terrain_spec",
]
