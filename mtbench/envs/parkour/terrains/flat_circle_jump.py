"""Pit with six flat round pillars to jump from one to the next."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 8
DIFFICULTY_RANGE = (0.1, 1.0)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Pillar radius ``R - lip`` with ``R ~ U(20 - 0.5d, 21 + 1.2d)`` and ``lip ~ U(10 + 0.4d, 10.1 + 0.6d)`` **cells**
    (about 0.5 m), flat top ``U(0.1 + 0.08d, 0.2 + 0.1d)`` m; centres ``int(s + R - lip)`` cells apart with
    ``s ~ U(0.4 + 0.7d, 0.5 + 0.8d)`` m, shifts ``U(-0.2 + 0.15d, 0.2 + 0.15d)`` m along and across. At low difficulty
    the pillars overlap each other (and the first one the end of the spawn zone), as in the original."""
    radius_lo, radius_hi = 20 - 0.5 * d, 21 + 1.2 * d
    lip_lo, lip_hi = 10 + 0.4 * d, 10.1 + 0.6 * d
    height_lo, height_hi = 0.1 + 0.08 * d, 0.2 + 0.1 * d
    spacing_lo, spacing_hi = tile.cells(0.4 + 0.7 * d), tile.cells(0.5 + 0.8 * d)
    dx_lo, dx_hi = tile.cells(-0.2 + 0.15 * d), tile.cells(0.2 + 0.15 * d)
    dy_lo, dy_hi = tile.cells(-0.2 + 0.15 * d), tile.cells(0.2 + 0.15 * d)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length + spacing_hi
    tile.fill_pit()
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        radius = rng.uniform(radius_lo, radius_hi)
        top = rng.uniform(height_lo, height_hi)
        lip = rng.uniform(lip_lo, lip_hi)
        cx, cy = int(x + dx), int(mid_y + dy)
        window, _, mask = tile.disc(cx, cy, radius - lip)
        tile.heights[window][mask] = top
        goals[i + 1] = [cx, cy]
        spacing = rng.uniform(spacing_lo, spacing_hi)
        x += int(spacing + radius - lip)
    goals[-1] = [int(x + tile.cells(0.5)), mid_y]
    tile.fill_from(x, 0.0)
    return goals
