"""Pit with six small domes to jump from one to the next."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, PIT_HEIGHT, Tile

TASK_ID = 9
DIFFICULTY_RANGE = (-0.3, 0.7)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Dome ``max(previous, h - (r/R)^2)`` out to ``r = R - lip`` with ``R ~ U(20 - 2.5d, 21 - 2.5d)`` and
    ``lip ~ U(3 + 1.5d, 3.5 + 2d)`` **cells**, ``h ~ U(0.1 + 0.05d, 0.15 + 0.07d)`` m; everything below
    ``-0.35 / (d + 2)^2`` m becomes pit, so a dome's rim sits a little below 0. Centres on a line ``int(s + R - lip)``
    cells apart (``s ~ U(0.4 + 0.4d, 0.5 + 0.5d)`` m, no shift along), ``randint(-0.2 + 0.15d, 0.2 + 0.15d m)`` cells
    across. Domes reaching into the spawn zone are cut off there (the original restores it afterwards)."""
    radius_lo, radius_hi = 20 - 2.5 * d, 21 - 2.5 * d
    lip_lo, lip_hi = 3 + 1.5 * d, 3.5 + 2.0 * d
    height_lo, height_hi = 0.1 + 0.05 * d, 0.15 + 0.07 * d
    spacing_lo, spacing_hi = tile.cells(0.4 + 0.4 * d), tile.cells(0.5 + 0.5 * d)
    dy_lo, dy_hi = tile.cells(-0.2 + 0.15 * d), tile.cells(0.2 + 0.15 * d)
    rim = -0.35 / (d + 2) ** 2
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length + spacing_lo
    tile.fill_pit()
    for i in range(6):
        dy = rng.randint(dy_lo, dy_hi)
        radius = rng.uniform(radius_lo, radius_hi)
        peak = rng.uniform(height_lo, height_hi)
        lip = rng.uniform(lip_lo, lip_hi)
        window, distance, mask = tile.disc(x, mid_y + dy, radius - lip)
        patch = tile.heights[window]
        patch[mask] = np.maximum(patch[mask], peak - (distance[mask] / radius) ** 2)
        patch[patch < rim] = PIT_HEIGHT
        goals[i + 1] = [x, mid_y + dy]
        spacing = rng.uniform(spacing_lo, spacing_hi)
        x += int(spacing + radius - lip)
    tile.heights[:tile.spawn_length, :] = 0.0
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
