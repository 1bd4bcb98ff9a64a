"""Pit with six platforms that slope across the path, each offset to one side, to jump between."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 10
DIFFICULTY_RANGE = (0.2, 1.1)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Platform length ``1.2 - 0.5d`` m, width ``U(1, 1 + 0.1d)`` m, high edge ``U(0.05 + 0.25d, 0.05 + 0.5d)`` m,
    gap ``0.1 + 0.65d`` m; with probability 1/2 a platform is moved 0.5 m to the right (-y) and slopes down towards
    the centre line, otherwise it is centred and slopes down to the right. Shifts ``U(-0.1, 0.1)`` m along and across.

    As in the original, the cross profile is ``top * (n - k) / n`` over ``k = 0..n-1`` of the platform's ``n`` columns
    ``[y1, y2)``; a centred platform is drawn one column over, on ``(y1, y2]``.
    """
    length = tile.cells(1.2 - 0.5 * d)
    width = tile.cells(rng.uniform(1.0, 1.0 + 0.1 * d))
    top_lo, top_hi = 0.05 + 0.25 * d, 0.05 + 0.5 * d
    gap = tile.cells(0.1 + 0.65 * d)
    y_offset = tile.cells(-0.5)
    dx_lo, dx_hi = tile.cells(-0.1), tile.cells(0.1)
    dy_lo, dy_hi = tile.cells(-0.1), tile.cells(0.1)
    mid_y = tile.mid_y
    half = width // 2
    span = 2 * half
    profile = (span - np.arange(span)) / span if span > 0 else np.zeros(0)

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    tile.fill_pit()
    x = tile.spawn_length
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        shifted = rng.uniform(0, 1) > 0.5
        y_mid = int(mid_y + shifted * y_offset + dy)
        top = rng.uniform(top_lo, top_hi)
        x_end = int(x + length + dx)
        y1, y2 = y_mid - half, y_mid + half
        values = top * profile
        if shifted:  # highest at y1, falling towards y2 - 1
            tile.heights[x:x_end, y1:y2] = values[None, :]
        else:  # highest at y2, falling towards y1 + 1
            tile.heights[x:x_end, y1 + 1:y2 + 1] = values[::-1][None, :]
        goals[i + 1] = [x + (length + dx) / 2, y_mid]
        x += int(length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
