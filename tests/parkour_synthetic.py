"""A small synthetic Parkour terrain with the interface of ``mtbench.envs.parkour.terrain.Terrain``.

Used by the env tests so that their expected values do not depend on the terrain generator: flat tiles, and tiles
with a box step (``step_height * (row + 1)`` m high from ``step_start`` to ``step_start + 2`` m) followed by a 1 m deep
pit up to 1 m before the tile's end; known heights, goals on the centre line. Tile (i, j) spans x in [i*L, (i+1)*L],
y in [j*W, (j+1)*W]; cell (a, b) is at world (-border + a*hs, -border + b*hs).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtbench.envs.parkour.terrains import NUM_GOALS, TERRAIN_NAMES


@dataclass(frozen=True)
class SyntheticConfig:
    columns: tuple[str, ...] = ("flat", "box_jump_even")
    num_rows: int = 2
    easy: bool = False
    tile_length: float = 8.0
    tile_width: float = 4.0
    horizontal_scale: float = 0.05
    vertical_scale: float = 0.005
    border_size: float = 2.0
    seed: int = 0
    num_goals: int = NUM_GOALS
    step_height: float = 0.2  # box height of the non-flat tiles (m)
    step_start: float = 3.0  # x (m, tile frame) where the box starts; the pit starts 2 m later
    pit_depth: float = 1.0
    goal_spacing: float = 0.6  # m between goals along the centre line, from x = 1.5
    extra: dict = field(default_factory=dict)


@dataclass(frozen=True)
class SyntheticTerrain:
    config: SyntheticConfig
    heights: np.ndarray
    tile_origins: np.ndarray
    goals: np.ndarray
    difficulty: np.ndarray
    task_ids: np.ndarray

    @property
    def border(self) -> float:
        return self.config.border_size

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        cfg = self.config
        a = np.clip(np.round((np.asarray(x) + cfg.border_size) / cfg.horizontal_scale).astype(int), 0,
                    self.heights.shape[0] - 1)
        b = np.clip(np.round((np.asarray(y) + cfg.border_size) / cfg.horizontal_scale).astype(int), 0,
                    self.heights.shape[1] - 1)
        return self.heights[a, b]


def synthetic_terrain(config: SyntheticConfig = SyntheticConfig()) -> SyntheticTerrain:
    cfg = config
    hs, border = cfg.horizontal_scale, cfg.border_size
    nrows, ncols = cfg.num_rows, len(cfg.columns)
    lx, ly, b = round(cfg.tile_length / hs), round(cfg.tile_width / hs), round(border / hs)
    heights = np.zeros((nrows * lx + 2 * b + 1, ncols * ly + 2 * b + 1), dtype=np.float32)
    origins = np.zeros((nrows, ncols, 3), dtype=np.float32)
    goals = np.zeros((nrows, ncols, cfg.num_goals, 3), dtype=np.float32)
    difficulty = np.zeros((nrows, ncols), dtype=np.float32)
    for i in range(nrows):
        for j, name in enumerate(cfg.columns):
            x0, y0 = i * cfg.tile_length, j * cfg.tile_width
            if name != "flat":
                a0 = b + i * lx + round(cfg.step_start / hs)
                a1 = a0 + round(2.0 / hs)
                ys = slice(b + j * ly + 10, b + (j + 1) * ly - 10)
                heights[a0:a1, ys] = cfg.step_height * (i + 1)
                heights[a1: b + (i + 1) * lx - round(1.0 / hs), ys] = -cfg.pit_depth
            origins[i, j] = (x0 + 1.0, y0 + 0.5 * cfg.tile_width, 0.0)
            gx = x0 + 1.5 + cfg.goal_spacing * np.arange(cfg.num_goals)
            goals[i, j, :, 0] = gx
            goals[i, j, :, 1] = y0 + 0.5 * cfg.tile_width
            difficulty[i, j] = i / max(nrows - 1, 1)
    task_ids = np.array([TERRAIN_NAMES.index(name) for name in cfg.columns], dtype=np.int64)
    terrain = SyntheticTerrain(cfg, heights, origins, goals, difficulty, task_ids)
    goals[..., 2] = terrain.height_at(goals[..., 0], goals[..., 1])
    return terrain
