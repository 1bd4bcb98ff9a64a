"""The Parkour terrain grid: difficulty rows x task columns of 18 m x 4 m tiles in one height field (pure numpy).

Layout (the original's ``terrain_utils.Terrain``): x runs along each tile's length, with the difficulty rows stacked
along x; y runs across, with the task columns stacked along y; z is up. World (0, 0) is the corner of tile (0, 0);
a flat border of ``border_size`` metres lies around the grid at negative coordinates and beyond the last tile. Tile
``(i, j)`` spans ``x in [i L, (i+1) L]``, ``y in [j W, (j+1) W]``; its robot spawns at ``(i L + 1, (j + 0.5) W)``.

Per tile, in the original's order: seed a ``np.random.RandomState`` from the tile's position, draw the terrain with
the row's difficulty (forced to 0 afterwards when ``easy``), quantise the heights to ``vertical_scale`` by
truncation (the original's ``astype(int16)``), add roughness, then raise 2-cell walls on all four tile edges.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .terrains import NUM_GOALS, TERRAIN_NAMES, Tile, terrain_spec


@dataclass(frozen=True)
class TerrainConfig:
    """What to generate. Defaults reproduce the original's 10 x 21 grid (``final_go1_hard``)."""

    columns: tuple[str, ...] = TERRAIN_NAMES
    """The terrain of each column (any subset, order or repeats of ``TERRAIN_NAMES``)."""
    num_rows: int = 10
    """Difficulty levels: row ``i`` has difficulty ``i / (num_rows - 1)`` (0.5 when there is a single row)."""
    easy: bool = False
    """Parkour-easy: draw every tile at difficulty 0 (the seeds still follow the rows, as in the original)."""
    tile_length: float = 18.0
    tile_width: float = 4.0
    horizontal_scale: float = 0.05
    vertical_scale: float = 0.005
    border_size: float = 5.0
    seed: int = 0
    """0 seeds tile ``(i, j)`` with the original's ``int(j / num_cols * 1e3 + d_i * 1e6)``; any other value seeds
    it with ``[that number, seed]`` (numpy's array seeding), giving a different but equally reproducible grid."""
    roughness: tuple[float, float] = (0.02, 0.04)
    """Roughness amplitude ``a ~ U(lo, hi)`` per tile; heights get uniform noise in ``[-a, a]`` (the original's
    ``height: [0.02, 0.06]`` sampled up to its midpoint)."""
    roughness_step: float = 0.005
    """Spacing of the noise levels (metres)."""
    roughness_scale: float = 0.075
    """Spacing of the random noise samples (metres); they are linearly interpolated to the grid."""
    wall_width: float = 0.1
    wall_height: float = 0.495
    """The original's ``int(0.5 // vertical_scale)`` = 99 units."""

    def __post_init__(self) -> None:
        if not self.columns:
            raise ValueError("columns must name at least one terrain; valid choices: " + ", ".join(TERRAIN_NAMES))
        for name in self.columns:
            terrain_spec(name)
        if self.num_rows < 1:
            raise ValueError(f"num_rows must be >= 1, got {self.num_rows}")
        for name in ("tile_length", "tile_width", "horizontal_scale", "vertical_scale", "roughness_scale"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("border_size", "wall_width", "wall_height"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        lo, hi = self.roughness
        if not 0 <= lo <= hi:
            raise ValueError(f"roughness must be (lo, hi) with 0 <= lo <= hi, got {self.roughness}")
        if not self.roughness_step >= self.vertical_scale:
            raise ValueError(f"roughness_step must be >= vertical_scale ({self.vertical_scale}), "
                             f"got {self.roughness_step}")
        if self.roughness_scale < self.horizontal_scale:
            raise ValueError(f"roughness_scale must be >= horizontal_scale ({self.horizontal_scale}), "
                             f"got {self.roughness_scale}")

    @property
    def num_cols(self) -> int:
        return len(self.columns)

    @property
    def tile_cells(self) -> tuple[int, int]:
        """Cells per tile along x and across (360, 80)."""
        return int(self.tile_length / self.horizontal_scale), int(self.tile_width / self.horizontal_scale)

    @property
    def border_cells(self) -> int:
        return int(self.border_size / self.horizontal_scale)

    def row_difficulty(self, row: int) -> float:
        """The difficulty of row ``row`` before ``easy`` is applied."""
        return row / (self.num_rows - 1) if self.num_rows > 1 else 0.5

    def tile_seed(self, row: int, col: int) -> int:
        """The original's per-tile seed ``int(j / num_cols * 1e3 + d_i * 1e6)``."""
        return int(col / self.num_cols * 1e3 + self.row_difficulty(row) * 1e6)


@dataclass(frozen=True, eq=False)
class Terrain:
    """A generated grid. Heights are metres, quantised to ``vertical_scale``; cell ``(a, b)`` is centred at world
    ``(-border + a hs, -border + b hs)`` with ``border = border_cells * hs``."""

    config: TerrainConfig
    heights: np.ndarray
    """float32 ``[nx, ny]``."""
    tile_origins: np.ndarray
    """float32 ``[num_rows, num_cols, 3]`` spawn origins; z is the highest ground within 0.5 m of the origin."""
    goals: np.ndarray
    """float32 ``[num_rows, num_cols, 8, 3]`` waypoints in world metres; z is the ground height there."""
    difficulty: np.ndarray
    """float32 ``[num_rows, num_cols]``: the row difficulty each tile was drawn with (0 everywhere when easy)."""
    task_ids: np.ndarray = field(repr=False)
    """int64 ``[num_cols]``: each column's task id (index in ``TERRAIN_NAMES``)."""

    @property
    def border(self) -> float:
        """Metres from the grid's first cell centre to world 0."""
        return self.config.border_cells * self.config.horizontal_scale

    def cell_index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nearest cell to world ``(x, y)``, clipped to the grid."""
        hs = self.config.horizontal_scale
        a = np.clip(np.rint((np.asarray(x, dtype=np.float64) + self.border) / hs), 0, self.heights.shape[0] - 1)
        b = np.clip(np.rint((np.asarray(y, dtype=np.float64) + self.border) / hs), 0, self.heights.shape[1] - 1)
        return a.astype(np.int64), b.astype(np.int64)

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Height of the nearest cell to world ``(x, y)`` (points off the grid take the nearest edge cell)."""
        return self.heights[self.cell_index(x, y)]

    def tile_window(self, row: int, col: int) -> tuple[slice, slice]:
        """The slices of ``heights`` that hold tile ``(row, col)``."""
        length, width = self.config.tile_cells
        b = self.config.border_cells
        return (slice(b + row * length, b + (row + 1) * length), slice(b + col * width, b + (col + 1) * width))

    def tile_heights(self, row: int, col: int) -> np.ndarray:
        """Tile ``(row, col)``'s heights ``[length, width]``, x along the tile (a view)."""
        return self.heights[self.tile_window(row, col)]


def _interpolate_axis(values: np.ndarray, coarse: np.ndarray, fine: np.ndarray, axis: int) -> np.ndarray:
    """Piecewise-linear interpolation of ``values`` sampled at ``coarse`` onto ``fine`` along ``axis``."""
    values = np.moveaxis(values, axis, 0)
    if len(coarse) == 1:
        out = np.repeat(values[:1], len(fine), axis=0)
    else:
        k = np.clip(np.searchsorted(coarse, fine, side="right") - 1, 0, len(coarse) - 2)
        t = ((fine - coarse[k]) / (coarse[k + 1] - coarse[k])).reshape(-1, *([1] * (values.ndim - 1)))
        out = (1.0 - t) * values[k] + t * values[k + 1]
    return np.moveaxis(out, 0, axis)


def roughness_units(rng: np.random.RandomState, length_cells: int, width_cells: int,
                    config: TerrainConfig) -> np.ndarray:
    """Uniform noise for one tile in ``vertical_scale`` units (int16 ``[length, width]``).

    Re-implements isaacgym's ``random_uniform_terrain(-a, a, step, downsampled_scale)`` with ``a ~ U(roughness)``:
    levels ``int(-a / vs) .. int(a / vs)`` in steps of ``step / vs`` units, drawn (``rng.choice``) on a coarse grid
    of ``int(length m / scale) x int(width m / scale)`` points spanning the tile, bilinearly interpolated to the
    cells and rounded to whole units.
    """
    hs, vs = config.horizontal_scale, config.vertical_scale
    amplitude = rng.uniform(*config.roughness)
    lo, hi = int(-amplitude / vs), int(amplitude / vs)
    step = int(config.roughness_step / vs)
    levels = np.arange(lo, hi + step, step)
    length_m, width_m = length_cells * hs, width_cells * hs
    coarse_shape = (max(int(length_m / config.roughness_scale), 1), max(int(width_m / config.roughness_scale), 1))
    coarse = rng.choice(levels, coarse_shape).astype(np.float64)
    along = _interpolate_axis(coarse, np.linspace(0, length_m, coarse_shape[0]),
                              np.linspace(0, length_m, length_cells), axis=0)
    fine = _interpolate_axis(along, np.linspace(0, width_m, coarse_shape[1]), np.linspace(0, width_m, width_cells),
                             axis=1)
    return np.rint(fine).astype(np.int16)


def _tile_rng(config: TerrainConfig, row: int, col: int) -> np.random.RandomState:
    seed = config.tile_seed(row, col)
    return np.random.RandomState(seed if config.seed == 0 else [seed, config.seed])


def generate_terrain(config: TerrainConfig | None = None) -> Terrain:
    """Generate the whole grid (see the module docstring for the steps)."""
    config = config or TerrainConfig()
    hs, vs = config.horizontal_scale, config.vertical_scale
    length, width = config.tile_cells
    border = config.border_cells
    rows, cols = config.num_rows, config.num_cols
    seeds = {config.tile_seed(i, j) for i in range(rows) for j in range(cols)}
    if len(seeds) != rows * cols:
        raise ValueError(f"a {rows} x {cols} grid gives repeated tile seeds with the original's seed formula; "
                         "use at most 1000 columns and 1001 rows")
    wall = int(round(config.wall_width / hs))
    wall_units = int(round(config.wall_height / vs))
    spawn_window = (slice(int(0.5 / hs), int(1.5 / hs)),
                    slice(int((config.tile_width / 2 - 0.5) / hs), int((config.tile_width / 2 + 0.5) / hs)))

    raw = np.zeros((rows * length + 2 * border, cols * width + 2 * border), dtype=np.int16)
    origins = np.zeros((rows, cols, 3))
    goals = np.zeros((rows, cols, NUM_GOALS, 3))
    difficulty = np.zeros((rows, cols))
    for j, name in enumerate(config.columns):
        spec = terrain_spec(name)
        for i in range(rows):
            rng = _tile_rng(config, i, j)
            d = 0.0 if config.easy else config.row_difficulty(i)
            tile = Tile.empty(length, width, hs)
            tile_goals = spec.generate(rng, spec.effective_difficulty(d), tile)
            units = (tile.heights / vs).astype(np.int16)
            units += roughness_units(rng, length, width, config)
            if wall > 0:
                units[:wall, :] = units[-wall:, :] = wall_units
                units[:, :wall] = units[:, -wall:] = wall_units
            raw[border + i * length:border + (i + 1) * length, border + j * width:border + (j + 1) * width] = units
            difficulty[i, j] = d
            origins[i, j] = [i * config.tile_length + 1.0, (j + 0.5) * config.tile_width,
                             units[spawn_window].max() * vs]
            goals[i, j, :, :2] = tile_goals * hs + [i * config.tile_length, j * config.tile_width]

    terrain = Terrain(
        config=config,
        heights=(raw * vs).astype(np.float32),
        tile_origins=origins.astype(np.float32),
        goals=goals.astype(np.float32),
        difficulty=difficulty.astype(np.float32),
        task_ids=np.array([terrain_spec(n).task_id for n in config.columns], dtype=np.int64),
    )
    terrain.goals[..., 2] = terrain.height_at(terrain.goals[..., 0], terrain.goals[..., 1])
    return terrain
