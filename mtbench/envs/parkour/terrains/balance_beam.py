"""Pit crossed by a narrow beam at ground level (six segments end to end)."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 19
DIFFICULTY_RANGE = (0.5, 1.0)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Six segments ``0.5 + 1.5d`` m long and ``0.85 - 0.5d`` m wide (rounded down to an even cell count) on the centre
    line; a goal in the middle of each. No random numbers are drawn."""
    length = tile.cells(0.5 + 1.5 * d)
    width = tile.cells(0.85 - 0.5 * d)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    tile.fill_pit()
    x = tile.spawn_length
    for i in range(6):
        tile.box(x, x + length, mid_y, width, 0.0)
        goals[i + 1] = [x + length / 2, mid_y]
        x += int(length)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
