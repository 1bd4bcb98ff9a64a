"""Six ramps rising from the ground to a height, then dropping back to the ground."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile, linear_ramp

TASK_ID = 3
DIFFICULTY_RANGE = (0.4, 0.8)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Ramp length ``1.2 - 0.5d`` m, width ``1.5 - 0.5d`` m, top height ``U(0.1 + 0.5d, 0.2 + 0.6d)`` m, gap
    ``0.1 + 0.7d`` m; shifts ``U(-0.2, 0.2)`` m along, ``U(-0.1, 0.1)`` m across. The original places the goal at the
    floor of half the (shifted) ramp length, which is kept."""
    length = tile.cells(1.2 - 0.5 * d)
    width = tile.cells(1.5 - 0.5 * d)
    height_lo, height_hi = 0.1 + 0.5 * d, 0.2 + 0.6 * d
    gap = tile.cells(0.1 + 0.7 * d)
    dx_lo, dx_hi = tile.cells(-0.2), tile.cells(0.2)
    dy_lo, dy_hi = tile.cells(-0.1), tile.cells(0.1)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        x_end = int(x + length + dx)
        top = rng.uniform(height_lo, height_hi)
        tile.box(x, x_end, int(mid_y + dy), width, linear_ramp(0.0, top, x_end - x))
        goals[i + 1] = [x + (length + dx) // 2, mid_y + dy]
        x += int(length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
