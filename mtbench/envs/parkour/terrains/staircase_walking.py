"""Pit crossed by a narrow staircase of six low steps up, ending on a plateau."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 14
DIFFICULTY_RANGE = (0.0, 1.2)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Tread ``0.5 - 0.05d`` m, width ``1 - 0.45d`` m, rise ``U(0.05 + 0.1d, 0.07 + 0.15d)`` m per step; the ground
    after the last step stays at the top height."""
    return _staircase(rng, tile, tread_m=0.5 - 0.05 * d, width_m=1.0 - 0.45 * d,
                      rise=(0.05 + 0.1 * d, 0.07 + 0.15 * d))


def _staircase(rng: np.random.RandomState, tile: Tile, tread_m: float, width_m: float,
               rise: tuple[float, float]) -> np.ndarray:
    """Six steps up on the centre line across a pit, a goal on each tread (shared with ``staircase_climbing``)."""
    tread = tile.cells(tread_m)
    width = tile.cells(width_m)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    tile.fill_pit()
    x = tile.spawn_length
    height = 0.0
    for i in range(6):
        height += rng.uniform(*rise)
        tile.box(x, x + tread, mid_y, width, height)
        goals[i + 1] = [x + tread / 2, mid_y]
        x += int(tread)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, height)
    return goals
