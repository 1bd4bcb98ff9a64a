"""Pit with six ground-level platforms separated by gaps to jump across."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 6
DIFFICULTY_RANGE = (-0.1, 0.6)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Platform length ``1 - 0.3d`` m, width ``U(1, 1 + 0.1d)`` m, height 0, gap ``U(0.4 + 0.5d, 0.5 + 0.5d)`` m
    (drawn per gap); shifts ``U(-0.2, 0.2)`` m along, ``U(-0.1, 0.1)`` m across."""
    length = tile.cells(1.0 - 0.3 * d)
    width = tile.cells(rng.uniform(1.0, 1.0 + 0.1 * d))
    gap_lo, gap_hi = tile.cells(0.4 + 0.5 * d), tile.cells(0.5 + 0.5 * d)
    dx_lo, dx_hi = tile.cells(-0.2), tile.cells(0.2)
    dy_lo, dy_hi = tile.cells(-0.1), tile.cells(0.1)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    tile.fill_pit()
    x = tile.spawn_length
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        tile.box(x, int(x + length + dx), int(mid_y + dy), width, 0.0)
        goals[i + 1] = [x + (length + dx) / 2, mid_y + dy]
        gap = rng.uniform(gap_lo, gap_hi)
        x += int(length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, 0.0)
    return goals
