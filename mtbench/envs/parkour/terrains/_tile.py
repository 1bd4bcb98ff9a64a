"""The height grid of one Parkour tile while a terrain function draws into it, and the drawing helpers.

A tile is ``length x width`` cells of ``horizontal_scale`` metres (360 x 80 at the default 18 m x 4 m, 0.05 m).
Axis 0 (x) runs along the tile from the spawn end, axis 1 (y) across it; heights are metres (float64 while
drawing, quantised by the grid assembly afterwards). Positions and radii inside the terrain functions are in
cells, as in the original MTBench code: several radii and offsets there are plain cell counts (not metres), so
the geometry only matches the original at ``horizontal_scale = 0.05``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

NUM_GOALS = 8
"""Waypoints per tile (the original hard-codes 8)."""

SPAWN_LENGTH = 2.0
"""Metres of flat ground at the start of every tile (the robot spawns at x = 1 m)."""

PIT_HEIGHT = -1.0
"""Height of the pit (metres) that fills everything after the spawn zone in the jumping terrains."""


@dataclass
class Tile:
    """A tile's height grid (metres, float64 ``[length, width]``) being drawn by one terrain function."""

    heights: np.ndarray
    horizontal_scale: float

    @classmethod
    def empty(cls, length_cells: int, width_cells: int, horizontal_scale: float) -> Tile:
        return cls(np.zeros((length_cells, width_cells)), horizontal_scale)

    @property
    def length(self) -> int:
        """Cells along x."""
        return self.heights.shape[0]

    @property
    def width(self) -> int:
        """Cells across (y)."""
        return self.heights.shape[1]

    @property
    def mid_y(self) -> int:
        """The centre line (cell index across)."""
        return self.width // 2

    @property
    def length_m(self) -> float:
        return self.length * self.horizontal_scale

    def cells(self, metres: float) -> int:
        """Metres to a whole number of cells, rounded half to even (the original's ``m_to_idx``)."""
        return int(np.round(metres / self.horizontal_scale))

    @property
    def spawn_length(self) -> int:
        """Cells of the flat spawn zone (40)."""
        return self.cells(SPAWN_LENGTH)

    def start_goal(self) -> list[float]:
        """Goal 0: 0.5 m before the end of the spawn zone, on the centre line."""
        return [self.spawn_length - self.cells(0.5), self.mid_y]

    def fill_pit(self) -> None:
        """Lower everything after the spawn zone to the pit height."""
        self.heights[self.spawn_length:, :] = PIT_HEIGHT

    def fill_from(self, x: float, height: float) -> None:
        """Set every row from ``int(x)`` to the end of the tile to ``height`` (the ground after the obstacles)."""
        self.heights[int(x):, :] = height

    def box(self, x1: float, x2: float, y_mid: float, width: int, height: float | np.ndarray) -> None:
        """Fill rows ``[int(x1), int(x2))`` and columns ``[int(y_mid - width // 2), int(y_mid + width // 2))`` (the
        original's ``add_platform``) with ``height``, a number or a column ``[rows, 1]`` (a ramp along x). Slices
        clip at the tile edge as numpy slices do."""
        half = width // 2
        self.heights[int(x1):int(x2), int(y_mid - half):int(y_mid + half)] = height

    def disc(self, cx: float, cy: float, radius: float) -> tuple[tuple[slice, slice], np.ndarray, np.ndarray]:
        """Cells whose centre lies within ``radius`` cells of ``(cx, cy)``.

        Returns ``(window, distance, mask)``: a window of the grid that holds the whole disc, the distance of every
        window cell to the centre, and ``distance <= radius``. ``heights[window][mask]`` are the disc's cells.
        """
        x0 = max(int(np.floor(cx - radius)), 0)
        x1 = min(int(np.ceil(cx + radius)) + 1, self.length)
        y0 = max(int(np.floor(cy - radius)), 0)
        y1 = min(int(np.ceil(cy + radius)) + 1, self.width)
        x = np.arange(x0, max(x1, x0))[:, None]
        y = np.arange(y0, max(y1, y0))[None, :]
        distance = np.sqrt((x - cx) ** 2 + (y - cy) ** 2)
        return (slice(x0, max(x1, x0)), slice(y0, max(y1, y0))), distance, distance <= radius


def linear_ramp(start: float, rise: float, n: int) -> np.ndarray:
    """``start + rise * k / n`` for ``k = 0..n-1`` as a column ``[n, 1]`` (the original's per-row ramp loops)."""
    return (start + rise * (np.arange(n) / n))[:, None] if n > 0 else np.zeros((0, 1))
