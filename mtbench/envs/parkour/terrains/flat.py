"""Flat ground (roughness only); the goals wander up to 1 m left and right of the centre line."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, SPAWN_LENGTH, Tile

TASK_ID = 20
DIFFICULTY_RANGE = None  # difficulty is ignored


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Goals evenly spaced from x = 2 m to ``L - 2`` m, each ``randint(-1 m, 1 m)`` (in cells) off the centre line."""
    goals = np.zeros((NUM_GOALS, 2))
    goals[:, 0] = np.linspace(tile.cells(SPAWN_LENGTH), tile.cells(tile.length_m - 2), NUM_GOALS)
    goals[:, 1] = tile.mid_y
    goals[:, 1] += rng.randint(tile.cells(-1.0), tile.cells(1.0), size=NUM_GOALS)
    return goals
