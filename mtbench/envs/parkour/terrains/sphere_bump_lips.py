"""Six round bumps that end in a ledge (lip) all around, each about 5 cm higher than the last."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 2
DIFFICULTY_RANGE = (0.2, 1.1)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Bump radius ``R ~ U(20 - 5d, 21 - 5d)`` **cells**, lip ``U(10 - 2d, 11 - 2d)`` cells, peak
    ``h ~ U(0.1 + 0.4d, 0.15 + 0.45d) + 0.05 i`` m; profile ``h - (r/R)^3`` out to ``r = R - lip``, where it drops to
    the ground (the edge can be slightly below 0 at low difficulty, as in the original). Centres ``0.2 - 0.05d`` m +
    2R apart, shifts ``U(-0.4, 0.4)`` m along and ``U(-0.9, 0.9)`` m across. Goals are the (integer) bump centres."""
    radius_lo, radius_hi = 20 - 5 * d, 21 - 5 * d
    lip_lo, lip_hi = 10 - 2 * d, 11 - 2 * d
    height_lo, height_hi = 0.1 + 0.4 * d, 0.15 + 0.45 * d
    height_step = 0.05
    spacing = tile.cells(0.2 - 0.05 * d)
    dx_lo, dx_hi = tile.cells(-0.4), tile.cells(0.4)
    dy_lo, dy_hi = tile.cells(-0.9), tile.cells(0.9)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length + radius_hi
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        radius = rng.uniform(radius_lo, radius_hi)
        peak = rng.uniform(height_lo, height_hi) + height_step * i
        lip = rng.uniform(lip_lo, lip_hi)
        cx, cy = int(x + dx), int(mid_y + dy)
        window, distance, mask = tile.disc(cx, cy, radius - lip)
        tile.heights[window][mask] = peak - (distance[mask] / radius) ** 3
        goals[i + 1] = [cx, cy]
        x += spacing + 2 * radius
    goals[-1] = [int(x + tile.cells(0.5)), mid_y]
    return goals
