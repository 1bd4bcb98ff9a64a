"""Pit spanned by five full-width flights of six steps, alternately up and down, with a landing after each."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 13
DIFFICULTY_RANGE = (0.1, 0.9)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Tread ``0.25 - 0.1d`` m over the whole tile width, rise ``U(0.05 + 0.1d, 0.07 + 0.15d) + 0.05 (f // 2)`` m in
    flight ``f``; flights go up, down, up, down, up, each followed by a landing of five treads. The 8 goals are
    evenly spaced on the centre line from x = 2 m to the end of the last landing (the original has no goal at 1.5 m
    here). The ground after the stairs is at the final height."""
    tread = tile.cells(0.25 - 0.1 * d)
    rise_lo, rise_hi = 0.05 + 0.1 * d, 0.07 + 0.15 * d
    rise_step = 0.05
    mid_y = tile.mid_y

    tile.fill_pit()
    x = tile.spawn_length
    height = 0.0
    direction = -1
    for flight in range(5):
        direction *= -1
        for _ in range(6):
            height += direction * (rng.uniform(rise_lo, rise_hi) + rise_step * (flight // 2))
            tile.box(x, x + tread, mid_y, tile.width, height)
            x += int(tread)
        tile.box(x, x + tread * 5, mid_y, tile.width, height)
        x += int(tread * 5)
    goals = np.zeros((NUM_GOALS, 2))
    goals[:, 0] = np.linspace(tile.spawn_length, x, NUM_GOALS)
    goals[:, 1] = mid_y
    tile.fill_from(x, height)
    return goals
