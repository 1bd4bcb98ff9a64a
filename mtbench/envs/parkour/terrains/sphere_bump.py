"""Six smooth round bumps scattered along the tile, to walk over."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 5
DIFFICULTY_RANGE = (0.3, 1.0)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Bump radius ``R ~ U(20 - 5.5d, 21 - 5.5d)`` **cells**, peak ``h ~ U(0.2 + 0.4d, 0.25 + 0.4d)`` m, profile
    ``max(h - (r/R)^(2 - 0.15d), 0)`` (so the visible bump is narrower than ``R``), centres ``0.2 - 0.05d`` m + 2R
    apart with shifts ``U(-0.4, 0.4)`` m along and ``U(-0.9, 0.9)`` m across. A later bump overwrites an earlier one
    where their discs overlap. Goals are the (integer) bump centres."""
    radius_lo, radius_hi = 20 - 5.5 * d, 21 - 5.5 * d
    height_lo, height_hi = 0.2 + 0.4 * d, 0.25 + 0.4 * d
    spacing = tile.cells(0.2 - 0.05 * d)
    power = 2 - 0.15 * d
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
        peak = rng.uniform(height_lo, height_hi)
        cx, cy = int(x + dx), int(mid_y + dy)
        window, distance, mask = tile.disc(cx, cy, radius)
        tile.heights[window][mask] = np.maximum(peak - (distance[mask] / radius) ** power, 0.0)
        goals[i + 1] = [cx, cy]
        x += spacing + 2 * radius
    goals[-1] = [int(x + tile.cells(0.5)), mid_y]
    return goals
