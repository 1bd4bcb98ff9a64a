"""Six ramps along the path that start with a ledge (lip) and rise further towards their far end."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile, linear_ramp

TASK_ID = 1
DIFFICULTY_RANGE = (0.6, 1.0)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Ramp length ``1.2 - 0.3d`` m, width ``U(1, 2)`` m, lip ``U(0.1 + 0.2d, 0.15 + 0.2d)`` m, rise over the ramp
    ``U(0.03 + 0.25d, 0.05 + 0.3d)`` m, gap ``0.7 + 0.3d`` m; shifts ``U(-0.3, 0.3)`` m along, ``U(-0.1, 0.1)`` m
    across."""
    length = tile.cells(1.2 - 0.3 * d)
    width = tile.cells(rng.uniform(1.0, 2.0))
    lip_lo, lip_hi = 0.1 + 0.2 * d, 0.15 + 0.2 * d
    rise_lo, rise_hi = 0.03 + 0.25 * d, 0.05 + 0.3 * d
    gap = tile.cells(0.7 + 0.3 * d)
    dx_lo, dx_hi = tile.cells(-0.3), tile.cells(0.3)
    dy_lo, dy_hi = tile.cells(-0.1), tile.cells(0.1)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        x_end = int(x + length + dx)
        rise = rng.uniform(rise_lo, rise_hi)
        lip = rng.uniform(lip_lo, lip_hi)
        tile.box(x, x_end, int(mid_y + dy), width, linear_ramp(lip, rise, x_end - x))
        goals[i + 1] = [x + (length + dx) / 2, mid_y + dy]
        x += int(length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
