"""Pit with twelve small rectangular stepping stones in side-by-side pairs at random lateral offsets."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 12
DIFFICULTY_RANGE = (0.3, 0.5)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Stone ``0.7 - 0.55d`` m long, ``0.6 - 0.3d`` m wide, at ground level; gap ``U(0.05 + 0.1d, 0.1 + 0.2d)`` m.

    The lateral placement follows the original step by step: offsets ``U(0.03 + 0.04d, 0.05 + 0.08d)`` m (kept in
    cells), a per-pair drift of ``0.02 i`` *cells*, mirrored when a stone would leave the band ``[w, W - 2w]``; the
    second stone of a pair starts ``int(gap)`` cells after the first and ``min(w (d + 1.5) / 2, 0.25 + 0.2d m)``
    across; the goal sits between the two (its lateral offset pulled back by ``0.7 w`` near the edges).
    """
    length = tile.cells(0.7 - 0.55 * d)
    width = tile.cells(0.6 - 0.3 * d)
    gap_lo, gap_hi = tile.cells(0.05 + 0.1 * d), tile.cells(0.1 + 0.2 * d)
    dy_lo, dy_hi = tile.cells(0.03 + 0.04 * d), tile.cells(0.05 + 0.08 * d)
    dy_drift = 0.02
    max_pair_offset = tile.cells(0.25 + 0.2 * d)
    mid_y = tile.mid_y
    tile_width = tile.width

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    tile.fill_pit()
    x = tile.spawn_length
    y = mid_y
    direction = 1
    for i in range(12):
        dy = min(rng.uniform(dy_lo, dy_hi), tile_width)
        direction *= -1
        y_change = direction * dy
        if y + y_change < width or y + y_change > tile_width - width * 2:
            y -= int(1.5 * y_change)
            y_change *= 0
        tile.box(x, x + length, y + y_change, width, 0.0)
        gap = rng.uniform(gap_lo, gap_hi)
        if i % 2 == 0:
            first_x, first_y = x, y
            x += int(gap)
            y_change = min(width * (d + 1.5) / 2, max_pair_offset)
            y += y_change
            if y < width * 1.5 or y > tile_width - width * 1.5:
                y_change += -0.7 * width
            goals[i // 2 + 1] = [first_x + int(gap) / 2, first_y + y_change / 2]
        else:
            x += int(length + 0.2 * gap)
            side = 1 if rng.uniform(0, 1) > 0.5 else -1
            y_change = side * rng.uniform(dy_lo, dy_hi) + dy_drift * i
            y = mid_y + y_change
            if y < width * 3 or y > tile_width - width * 2:
                y += -1.5 * y_change
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
