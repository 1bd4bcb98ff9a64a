"""A round spiral staircase: a disc cut into 14 sectors that rise one after another around its centre."""

from __future__ import annotations

import numpy as np

from ._tile import NUM_GOALS, Tile

TASK_ID = 16
DIFFICULTY_RANGE = None  # the original lists (0, 1) but never applies it: the spiral is drawn with the raw d

NUM_SECTORS = 14
RADIUS_UNITS = 25.0
"""The original measures the disc in units of ``width / 2 / 25`` cells (25 units = half the tile width)."""


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Disc of radius ``(1 - 0.35d)`` half tile widths (2 m at d = 0), centred ``2 m + W/2`` (6 m) along the tile on
    the centre line; sector ``k`` spans angles ``[-pi + k pi/7, -pi + (k+1) pi/7]`` (measured from +x, starting
    behind the centre, i.e. on the spawn side) and stands ``sum of k draws of U(0.05 + 0.15d, 0.05 + 0.2d)`` m high.

    Goal 0 is ``10 (1 - 0.35d)`` cells before x = 4 m and 0.3 m right of the centre line; goals 1..7 sit on the odd
    sectors 1, 3, ..., 13 at 0.75 of half the disc radius (in the original's units, added to cells as it does).
    There is no goal after the last sector. The original draws an unused platform width ``U(1, 2)`` first; it is
    drawn here too so that the tile's later random numbers (its roughness) match. The original builds the sector
    mask with ``np.bool8``, which NumPy 2 removed; the geometry is reproduced.
    """
    rng.uniform(1.0, 2.0)  # the original's unused platform width
    size = tile.width
    centre = size // 2
    rise_lo, rise_hi = 0.05 + 0.15 * d, 0.05 + 0.2 * d
    shrink = 1 - 0.35 * d
    x0 = 2 * tile.spawn_length
    if x0 + size > tile.length:
        raise ValueError(f"staircase_spiral needs a tile at least {x0 + size} cells long (got {tile.length})")

    grid_x, grid_y = np.mgrid[0:size, 0:size]
    unit_x = (grid_x - centre) / (size / 2) * RADIUS_UNITS
    unit_y = (grid_y - centre) / (size / 2) * RADIUS_UNITS
    radius = np.sqrt(unit_x**2 + unit_y**2)
    theta = np.arctan2(unit_y, unit_x)
    inside = radius <= RADIUS_UNITS * shrink
    disc = tile.heights[x0:x0 + size, :size]

    goals = np.zeros((NUM_GOALS, 2))
    goals[0] = [tile.spawn_length * 2 - shrink * 10, centre - tile.cells(0.3)]
    height = 0.0
    for k in range(NUM_SECTORS):
        lo, hi = -np.pi + np.pi * k / 7, -np.pi + np.pi * (k + 1) / 7
        disc[inside & (theta >= lo) & (theta <= hi)] = height
        if k % 2 == 1:
            mid = (lo + hi) / 2
            goals[k // 2 + 1] = [np.cos(mid) * RADIUS_UNITS / 2 * 1.5 * shrink + centre + x0,
                                 np.sin(mid) * RADIUS_UNITS / 2 * 1.5 * shrink + centre]
        height += rng.uniform(rise_lo, rise_hi)
    return goals
