"""Six A-frames: a ramp up to a peak immediately followed by a ramp back down, with gaps between them."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile, linear_ramp

TASK_ID = 4
DIFFICULTY_RANGE = (0.55, 0.9)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Each half ``1 - 0.4d`` m long, width ``1.5 - 0.5d`` m, peak ``U(0.1 + 0.6d, 0.15 + 0.6d)`` m, foot heights
    ``U(0.01 + 0.05d, 0.03 + 0.03d)`` m, gap ``0.1 + 0.7d`` m; shifts ``U(-0.2, 0.2)`` m along, ``U(-0.1, 0.1)`` m
    across. The goal sits on the peak."""
    half_length = tile.cells(1.0 - 0.4 * d)
    width = tile.cells(1.5 - 0.5 * d)
    peak_lo, peak_hi = 0.1 + 0.6 * d, 0.15 + 0.6 * d
    foot_lo, foot_hi = 0.01 + 0.05 * d, 0.03 + 0.03 * d
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
        peak = rng.uniform(peak_lo, peak_hi)
        x_end = int(x + half_length + dx)
        foot = rng.uniform(foot_lo, foot_hi)
        tile.box(x, x_end, int(mid_y + dy), width, linear_ramp(foot, peak, x_end - x))
        x += int(half_length + dx)
        x_end = int(x + half_length + dx)
        foot = rng.uniform(foot_lo, foot_hi)
        tile.box(x, x_end, int(mid_y + dy), width, linear_ramp(peak, -(peak - foot), x_end - x))
        goals[i + 1] = [x, mid_y + dy]
        x += int(half_length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
