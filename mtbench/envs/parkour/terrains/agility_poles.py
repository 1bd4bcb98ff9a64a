"""Six thin 1 m poles on the centre line; the goals alternate left and right of them (a slalom)."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 18
DIFFICULTY_RANGE = (0.0, 1.0)

POLE_RADIUS = 3
"""Cells (0.15 m at the default scale)."""
POLE_HEIGHT = 1.0


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Poles of radius 3 cells, spaced ``2 - 1.15d`` m + 6 cells apart (the first one spacing after the spawn zone);
    goal ``k`` is beside pole ``k`` at ``+-(0.9 - 0.07d)`` m, starting on the left. No random numbers are drawn.

    Deviation: the original puts the last goal 0.5 m past the position a seventh pole would have. At low difficulty
    (rows 0-2 of Parkour-hard, every Parkour-easy tile) that is in or beyond the tile's end wall: 17.95 m, 19.0 m and
    20.05 m along an 18 m tile, the last two in the next row's tile. Here the goal is kept at most 0.5 m before the
    end of the tile (17.5 m, 0.35 m past the last pole's edge at d = 0); the obstacles are unchanged.
    """
    spacing = tile.cells(2 - 1.15 * d)
    goal_offset = tile.cells(0.9 - 0.07 * d)
    mid_y = tile.mid_y

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = tile.start_goal()
    x = tile.spawn_length + spacing
    side = 1
    for i in range(6):
        window, _, mask = tile.disc(x, mid_y, POLE_RADIUS)
        tile.heights[window][mask] = POLE_HEIGHT
        goals[i + 1] = [x, mid_y + goal_offset * side]
        side *= -1
        x += spacing + 2 * POLE_RADIUS
    goals[-1] = [min(x + tile.cells(0.5), tile.length - tile.cells(0.5)), mid_y]
    return goals
