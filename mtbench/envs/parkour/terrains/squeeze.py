"""Six pairs of tall walls forming narrow gates to walk through."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 17
DIFFICULTY_RANGE = (0.0, 1.0)

WALL_HEIGHT = 0.7
WALL_THICKNESS = 0.5


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Walls 0.7 m high, 0.5 m thick, ``0.6 + 0.4d`` m long; the opening between a pair is
    ``randint(0.5 - 0.15d, 0.6 - 0.15d m in cells) - 0.005d i`` cells (rounded down to even), gap between gates
    ``U(0.4 - 0.1d, 0.5 - 0.1d)`` m; shifts ``U(-0.1, 0.1)`` m along and across. The goal is in the opening."""
    length = tile.cells(0.6 + 0.4 * d)
    thickness = tile.cells(WALL_THICKNESS)
    gap_lo, gap_hi = tile.cells(0.4 - 0.1 * d), tile.cells(0.5 - 0.1 * d)
    opening_lo, opening_hi = tile.cells(0.5 - 0.15 * d), tile.cells(0.6 - 0.15 * d)
    opening_shrink = 0.005 * d
    dx_lo, dx_hi = tile.cells(-0.1), tile.cells(0.1)
    dy_lo, dy_hi = tile.cells(-0.1), tile.cells(0.1)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        opening = rng.randint(opening_lo, opening_hi) - i * opening_shrink
        x_end = int(x + length + dx)
        tile.box(x, x_end, int(mid_y + dy + thickness // 2 + opening // 2), thickness, WALL_HEIGHT)
        tile.box(x, x_end, int(mid_y + dy - thickness // 2 - opening // 2), thickness, WALL_HEIGHT)
        goals[i + 1] = [x + (length + dx) / 2, mid_y + dy]
        gap = rng.uniform(gap_lo, gap_hi)
        x += int(length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
