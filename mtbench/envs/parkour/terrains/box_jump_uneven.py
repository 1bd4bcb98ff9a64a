"""Pit with six platforms of changing height (up or down from the last) separated by gaps to jump across."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 7
DIFFICULTY_RANGE = (-0.2, 0.8)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Platform length ``1.2 - 0.3d`` m, width ``U(1, 1 + 0.1d)`` m, height change ``c ~ U(0.01 + 0.2d, 0.02 + 0.25d)``
    m per platform, gap ``U(0.4 + 0.3d, 0.5 + 0.4d)`` m; shifts ``U(-0.3, 0.3)`` m along, ``U(-0.1, 0.1)`` m across.

    The height goes up by ``c``, or (with probability 1/2) down by ``c`` when that stays above 0. As in the original,
    at low difficulty ``c`` is negative (``d_eff < -0.05``), so "down" is always allowed and platforms step by
    ``|c|`` in either direction, possibly below the spawn level. The ground after the last platform is at its height.
    """
    length = tile.cells(1.2 - 0.3 * d)
    width = tile.cells(rng.uniform(1.0, 1.0 + 0.1 * d))
    change_lo, change_hi = 0.01 + 0.2 * d, 0.02 + 0.25 * d
    gap_lo, gap_hi = tile.cells(0.4 + 0.3 * d), tile.cells(0.5 + 0.4 * d)
    dx_lo, dx_hi = tile.cells(-0.3), tile.cells(0.3)
    dy_lo, dy_hi = tile.cells(-0.1), tile.cells(0.1)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    tile.fill_pit()
    x = tile.spawn_length
    height = 0.0
    for i in range(6):
        dx = rng.uniform(dx_lo, dx_hi)
        dy = rng.uniform(dy_lo, dy_hi)
        change = rng.uniform(change_lo, change_hi)
        direction = (1 if rng.uniform(0, 1) > 0.5 else -1) if height - change > 0 else 1
        height += direction * change
        tile.box(x, int(x + length + dx), int(mid_y + dy), width, height)
        goals[i + 1] = [x + (length + dx) / 2, mid_y + dy]
        gap = rng.uniform(gap_lo, gap_hi)
        x += int(length + dx + gap)
    goals[-1] = [x + tile.cells(0.5), mid_y]
    tile.fill_from(x, height)
    return goals
