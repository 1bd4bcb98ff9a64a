"""Pictures of a Parkour terrain grid (matplotlib).

``python -m mtbench.envs.parkour.render_terrain out.png [--easy] [--rows N] [--columns a,b,...] [--seed S]``
draws the whole grid from above, coloured by height (colorbar in metres), with tile borders, the difficulty of each
row along x, the task of each column along y and the waypoints numbered faintly. ``--tile ROW,COL`` draws one tile
instead: the top view and, below it, the height profile along the tile's centre line and through its waypoints.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import TwoSlopeNorm  # noqa: E402

from .terrain import Terrain, TerrainConfig, generate_terrain  # noqa: E402
from .terrains import TERRAIN_NAMES  # noqa: E402

CMAP = "terrain"
PIT_COLOUR_FLOOR = -1.0


def _norm(heights: np.ndarray, vmax: float | None) -> TwoSlopeNorm:
    top = float(heights.max()) if vmax is None else vmax
    return TwoSlopeNorm(vmin=min(float(heights.min()), PIT_COLOUR_FLOOR), vcenter=0.0, vmax=max(top, 0.1))


def render_grid(terrain: Terrain, path: str | Path, vmax: float | None = 1.5, dpi: int = 110) -> None:
    """Top view of the whole grid: x (tile length, difficulty rows) to the right, y (task columns) up."""
    cfg = terrain.config
    hs = cfg.horizontal_scale
    nx, ny = terrain.heights.shape
    x0 = y0 = -terrain.border - hs / 2
    extent = (x0, x0 + nx * hs, y0, y0 + ny * hs)
    length, width = cfg.tile_length, cfg.tile_width
    plot_w = 0.11 * nx * hs
    fig_w = plot_w + 4.5
    fig_h = plot_w * ny / nx + 1.6
    fig, ax = plt.subplots(figsize=(fig_w, fig_h))
    image = ax.imshow(terrain.heights.T, origin="lower", extent=extent, cmap=CMAP, norm=_norm(terrain.heights, vmax),
                      interpolation="nearest")
    for i in range(cfg.num_rows + 1):
        ax.axvline(i * length, color="k", lw=0.6)
    for j in range(cfg.num_cols + 1):
        ax.axhline(j * width, color="k", lw=0.6)
    goals = terrain.goals.reshape(-1, 8, 3)
    ax.plot(goals[..., 0].ravel(), goals[..., 1].ravel(), "o", ms=1.8, mfc="none", mec="red", mew=0.5, alpha=0.8)
    for tile_goals in goals:
        for k, (gx, gy, _) in enumerate(tile_goals):
            ax.text(gx + 0.15, gy + 0.15, str(k), fontsize=3.5, color="darkred", alpha=0.6)
    ax.set_xticks([(i + 0.5) * length for i in range(cfg.num_rows)])
    ax.set_xticklabels([f"row {i}\nd={terrain.difficulty[i, 0]:.2f}" for i in range(cfg.num_rows)], fontsize=7)
    ax.set_yticks([(j + 0.5) * width for j in range(cfg.num_cols)])
    ax.set_yticklabels([f"{name} ({TERRAIN_NAMES.index(name)})" for name in cfg.columns], fontsize=7)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    mode = "easy (d = 0 everywhere)" if cfg.easy else "hard (d = row / (rows - 1))"
    ax.set_title(f"Parkour terrain: {cfg.num_rows} x {cfg.num_cols} tiles of {length:g} x {width:g} m, {mode}, "
                 f"seed {cfg.seed}\nx along the tiles (m), world (0, 0) at the corner of tile (0, 0); "
                 "red circles: waypoints 0-7", fontsize=9)
    bar = fig.colorbar(image, ax=ax, fraction=0.025, pad=0.01, extend="max" if vmax is not None else "neither")
    bar.set_label("height (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)


def render_tile(terrain: Terrain, row: int, col: int, path: str | Path, dpi: int = 130) -> None:
    """One tile from above plus its height profile along the centre line and through the waypoints."""
    cfg = terrain.config
    if not (0 <= row < cfg.num_rows and 0 <= col < cfg.num_cols):
        raise ValueError(f"tile ({row}, {col}) is outside the {cfg.num_rows} x {cfg.num_cols} grid")
    hs = cfg.horizontal_scale
    heights = terrain.tile_heights(row, col)
    length, width = heights.shape
    x_base, y_base = row * cfg.tile_length, col * cfg.tile_width
    goals = terrain.goals[row, col]
    name = cfg.columns[col]

    aspect = width / length
    fig, (top, side) = plt.subplots(2, 1, figsize=(15, 2.2 + 12.5 * aspect + 3.2),
                                    gridspec_kw={"height_ratios": [12.5 * aspect, 3.2]})
    extent = (-hs / 2, (length - 0.5) * hs, -hs / 2, (width - 0.5) * hs)
    image = top.imshow(heights.T, origin="lower", extent=extent, cmap=CMAP, norm=_norm(heights, None),
                       interpolation="nearest", aspect="auto")
    gx, gy = goals[:, 0] - x_base, goals[:, 1] - y_base
    top.plot(gx, gy, "o", ms=6, mfc="none", mec="red", mew=1.2)
    for k in range(len(goals)):
        top.annotate(str(k), (gx[k], gy[k]), xytext=(4, 4), textcoords="offset points", color="darkred", fontsize=8)
    spawn = terrain.tile_origins[row, col]
    top.plot(spawn[0] - x_base, spawn[1] - y_base, "x", color="k", ms=7, label="spawn")
    top.axhline(cfg.tile_width / 2, color="k", lw=0.5, ls="--")
    top.set_ylabel("y in tile (m)")
    top.legend(loc="upper right", fontsize=8)

    xs = np.arange(length) * hs
    side.plot(xs, heights[:, width // 2], color="k", lw=1.0, label="centre line")
    ia = np.clip(np.rint(gx / hs).astype(int), 0, length - 1)
    ib = np.clip(np.rint(gy / hs).astype(int), 0, width - 1)
    wall = int(round(cfg.wall_width / hs))
    inner = heights[:, wall:width - wall] if 2 * wall < width else heights
    side.plot(xs, inner.max(axis=1), color="0.55", lw=0.8, ls=":", label="highest across (inside the walls)")
    side.plot(gx, goals[:, 2], "o", mfc="none", mec="red", mew=1.2, label="waypoints (z)")
    for k in range(len(goals)):
        side.annotate(str(k), (gx[k], goals[k, 2]), xytext=(4, 4), textcoords="offset points", color="darkred",
                      fontsize=8)
    side.plot(gx, heights[ia, ib], ".", color="red", ms=3)
    side.set_xlim(extent[0], extent[1])
    side.set_xlabel("x along the tile (m)")
    side.set_ylabel("height (m)")
    side.grid(alpha=0.3)
    side.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{name} (task {TERRAIN_NAMES.index(name)}), tile row {row} col {col}, "
                 f"d = {terrain.difficulty[row, col]:.2f}{' (easy)' if cfg.easy else ''}, seed {cfg.seed}")
    fig.colorbar(image, ax=[top, side], fraction=0.02, pad=0.01).set_label("height (m)")
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="output PNG path")
    parser.add_argument("--easy", action="store_true", help="difficulty 0 on every row (Parkour-easy)")
    parser.add_argument("--rows", type=int, default=10, help="difficulty rows (default 10)")
    parser.add_argument("--columns", default=None, help="comma-separated terrain names (default: all 21)")
    parser.add_argument("--seed", type=int, default=0, help="0 = the original's per-tile seeds")
    parser.add_argument("--tile", default=None, metavar="ROW,COL", help="draw only this tile, with a side profile")
    parser.add_argument("--vmax", type=float, default=1.5, help="top of the colour scale for the grid view (m)")
    parser.add_argument("--dpi", type=int, default=None)
    args = parser.parse_args(argv)
    columns = tuple(c.strip() for c in args.columns.split(",")) if args.columns else TERRAIN_NAMES
    terrain = generate_terrain(TerrainConfig(columns=columns, num_rows=args.rows, easy=args.easy, seed=args.seed))
    if args.tile:
        try:
            row, col = (int(v) for v in args.tile.split(","))
        except ValueError:
            parser.error(f"--tile must be ROW,COL (two integers), got {args.tile!r}")
        render_tile(terrain, row, col, args.out, **({"dpi": args.dpi} if args.dpi else {}))
    else:
        render_grid(terrain, args.out, vmax=args.vmax, **({"dpi": args.dpi} if args.dpi else {}))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
