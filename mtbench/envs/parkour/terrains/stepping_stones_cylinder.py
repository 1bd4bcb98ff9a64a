"""Pit with twelve round stepping stones in pairs that zig-zag across the centre line."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 11
DIFFICULTY_RANGE = (-0.2, 1.1)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Stone radius ``7 - 3.5d`` **cells**, height ``U(0, 0.07d)`` m, gap ``U(0.05 + 0.05d, 0.1 + 0.07d)`` m, lateral
    offset ``[0.15 - 0.05d, 0.2 - 0.05d)`` m (``randint`` in cells, so always the lower end).

    Stones come in pairs: the first of a pair below the running centre line, the second one radius further across
    and above it; the goal of a pair sits between them. As in the original, stone heights at ``d_eff < 0`` are drawn
    from ``U(0, 0.07 d_eff)``, i.e. slightly below 0.
    """
    height_lo, height_hi = 0, 0.07 * d
    gap_lo, gap_hi = tile.cells(0.05 + 0.05 * d), tile.cells(0.1 + 0.07 * d)
    radius = 7 - 3.5 * d
    dy_lo, dy_hi = tile.cells(0.15 - 0.05 * d), tile.cells(0.2 - 0.05 * d)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    tile.fill_pit()
    x = int(tile.spawn_length + radius / 2)
    y = mid_y
    direction = 1
    for i in range(12):
        dy = rng.randint(dy_lo, dy_hi)
        direction *= -1
        window, _, mask = tile.disc(x + radius / 2, y + direction * dy, radius)
        tile.heights[window][mask] = rng.uniform(height_lo, height_hi)
        gap = rng.uniform(gap_lo, gap_hi)
        if i % 2 == 0:
            x += int(gap + radius / 3)
            goals[i // 2 + 1] = [x, y + radius / 2]
            y += radius
        else:
            x += int(1.5 * gap + radius)
            y = mid_y
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
