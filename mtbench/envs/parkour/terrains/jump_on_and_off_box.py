"""Six boxes in a row, each about 5 cm higher than the last, with a gap of ground between them to jump down to."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 0
DIFFICULTY_RANGE = (0.1, 0.8)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Box length ``1.2 - 0.25d`` m, width ``U(1, 2)`` m, height ``U(0.1 + 0.55d, 0.15 + 0.55d) + 0.05 i`` m,
    gap ``1 - 0.1d`` m; each box shifted by ``U(-0.2, 0.2)`` m along and ``U(-0.1, 0.1)`` m across."""
    length = tile.cells(1.2 - 0.25 * d)
    width = tile.cells(rng.uniform(1.0, 2.0))
    height_lo, height_hi = 0.1 + 0.55 * d, 0.15 + 0.55 * d
    height_step = 0.05
    gap = tile.cells(1.0 - 0.1 * d)
    dx_lo, dx_hi = tile.cells(-0.2), tile.cells(0.2)
    dy_lo, dy_hi = tile.cells(-0.1), tile.cells(0.1)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        height = rng.uniform(height_lo, height_hi) + height_step * i
        tile.box(x, int(x + length + dx), int(mid_y + dy), width, height)
        goals[i + 1] = [x + (length + dx) / 2, mid_y + dy]
        x += int(length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
