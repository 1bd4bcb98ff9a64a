"""An analytic check that a Go1 can follow each tile's waypoints: geometry only, no physics.

Model, on the tile's cells (0.05 m) with its real heights (roughness included):

* A cell is **solid** when it lies inside the tile walls and above ``pit_height``, and **standable** when every
  cell within ``support_radius`` of it is solid (a region must be about 0.25 m wide to stand on) and the ground
  there is no steeper than ``max_slope``: the slope of a least-squares plane through the solid cells within
  ``slope_radius`` that are at most ``max_step_up`` above or below the cell (so a wall, pit or high step beside
  it does not count, a low step edge does).
* The robot **walks** between neighbouring standable cells (8-connected) whose heights differ by at most
  ``max_step_up`` (a step up or down). Cells connected this way form a *region*.
* It **steps over, steps down or jumps** along a straight line from the edge of one region to a standable cell of
  another (across a pit, a step edge or a stretch too steep to stand on) when the pit crossed (the non-solid cells
  under the line) is at most ``max_gap`` long, the line is at most ``max_gap + 2 support_radius`` plus one cell long
  (take-off and landing may be up to ``support_radius`` from the edges of the gap), the landing is at most
  ``max_step_up`` higher or ``max_step_down`` lower than the take-off, and no cell under the line is more than
  ``jump_clearance`` above both ends (no jumping through walls or poles).
* A waypoint is **on a surface** when its nearest cell is solid and a standable cell within ``support_radius`` of
  it, at most ``max_step_up`` higher or lower, belongs to a region the robot can get to from the spawn point (so
  it is not in a pit, nor inside or on top of a wall or pole it cannot climb). It is **reached** when the robot
  can stand on some cell within ``reach_radius`` of it (the env's goal threshold). The waypoints are followed in
  order from the spawn point: leg ``k`` starts from the regions in which waypoint ``k - 1`` was reached.

A tile is traversable when all 8 waypoints are on a surface and reached. ``Go1Reach`` states the limits and why.
``python -m mtbench.envs.parkour.traversability`` prints the per-terrain report for the 10 x 21 grid.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from .terrain import Terrain, TerrainConfig, generate_terrain
from .terrains import TERRAIN_NAMES, terrain_spec


@dataclass(frozen=True)
class Go1Reach:
    """What the model lets a Go1 do (metres)."""

    max_step_up: float = 0.35
    """Highest step up (walking or jumping). The Go1's leg is 0.43 m (thigh 0.213 + calf 0.213 m) and it stands
    with its hips about 0.3 m high, so a foot can be placed about that high; MTBench's d = 0 steps are at most 0.345 m."""
    max_step_down: float = 0.6
    """Deepest drop: twice the standing height, which a 12 kg quadruped lands on its legs."""
    max_gap: float = 0.7
    """Widest gap jumped. Extreme Parkour's A1 (arXiv 2309.14341), a robot of the Go1's size, long-jumps gaps of
    twice its length; 0.7 m leaves a margin. The widest gaps at d = 0 are bump_jump's last jump from the final dome to
    the ground (0.55-0.7 m along the centre line); box_jump_even's reach 0.6-0.7 m at d = 1."""
    jump_clearance: float = 0.1
    """Cells under a jump may stand at most this much above both its ends."""
    pit_height: float = -0.5
    """Cells below this are pit: the original terminates an episode when the base drops below z = -0.25 m."""
    support_radius: float = 0.1
    """Everything within this radius of a cell must be solid for the robot to stand there (feet 0.2-0.25 m apart
    across the body)."""
    max_slope: float = 1.0
    """Steepest ground stood on (45 degrees): standing on an incline needs a friction coefficient of at least its
    slope, and the original's terrain friction is 1.0. Roughness alone gives slopes below 0.3."""
    slope_radius: float = 0.15
    """Radius of the plane fitted to measure the slope (averages out the roughness)."""
    reach_radius: float = 0.3
    """The env's ``next_goal_threshold``: a waypoint counts as reached within this distance."""


@dataclass(frozen=True)
class TileReport:
    """The check of one tile."""

    terrain: str
    row: int
    col: int
    difficulty: float
    effective_difficulty: float
    on_surface: tuple[bool, ...]
    """Per waypoint: it is on a surface (see the module docstring)."""
    reached: int
    """How many waypoints were reached in order from the spawn point (8 = all)."""

    @property
    def traversable(self) -> bool:
        return all(self.on_surface) and self.reached == len(self.on_surface)

    @property
    def reason(self) -> str:
        """Empty when traversable, else what failed (goals past an unreachable one are not listed as off a
        surface: nothing beyond it can be got onto)."""
        problems = []
        off = [k for k, ok in enumerate(self.on_surface) if not ok and k < max(self.reached, 1)]
        if off:
            problems.append(f"goal{'s' if len(off) > 1 else ''} {','.join(map(str, off))} not on a surface")
        if self.reached < len(self.on_surface):
            problems.append(f"goal {self.reached} not reachable" + (f" from goal {self.reached - 1}"
                                                                    if self.reached else " from the spawn point"))
        return "; ".join(problems)


def _disc_offsets(radius_cells: float) -> np.ndarray:
    r = int(np.floor(radius_cells))
    dx, dy = np.mgrid[-r:r + 1, -r:r + 1]
    keep = dx**2 + dy**2 <= radius_cells**2 + 1e-9
    return np.stack([dx[keep], dy[keep]], axis=1)


def _shifted_all(mask: np.ndarray, offsets: np.ndarray, outside: bool) -> np.ndarray:
    """``out[a] = all(mask[a + o] for o in offsets)``, cells off the grid counting as ``outside``."""
    r = int(np.abs(offsets).max()) if len(offsets) else 0
    padded = np.pad(mask, r, constant_values=outside)
    out = np.ones_like(mask)
    nx, ny = mask.shape
    for ox, oy in offsets:
        out &= padded[r + ox:r + ox + nx, r + oy:r + oy + ny]
    return out


def _regions(standable: np.ndarray, heights: np.ndarray, max_step: float) -> np.ndarray:
    """Label of each cell's walking region (the smallest flat index in it); -1 for cells that are not standable."""
    nx, ny = standable.shape
    index = np.arange(nx * ny).reshape(nx, ny)
    us, vs = [], []
    for (ax, bx), (ay, by) in (((slice(0, -1), slice(1, None)), (slice(None), slice(None))),
                               ((slice(None), slice(None)), (slice(0, -1), slice(1, None))),
                               ((slice(0, -1), slice(1, None)), (slice(0, -1), slice(1, None))),
                               ((slice(0, -1), slice(1, None)), (slice(1, None), slice(0, -1)))):
        ok = standable[ax, ay] & standable[bx, by] & (np.abs(heights[ax, ay] - heights[bx, by]) <= max_step)
        us.append(index[ax, ay][ok])
        vs.append(index[bx, by][ok])
    u, v = np.concatenate(us), np.concatenate(vs)
    parent = np.arange(nx * ny)
    while True:
        pu, pv = parent[u], parent[v]
        differ = pu != pv
        if not differ.any():
            break
        np.minimum.at(parent, np.maximum(pu, pv)[differ], np.minimum(pu, pv)[differ])
        while True:
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
    labels = parent.reshape(nx, ny)
    return np.where(standable, labels, -1)


def _slope(heights: np.ndarray, solid: np.ndarray, radius_cells: float, same_surface: float) -> np.ndarray:
    """Per cell, the slope (rise per cell) of the least-squares plane through the solid cells within
    ``radius_cells`` whose height is within ``same_surface`` of the cell's own."""
    offsets = _disc_offsets(radius_cells)
    r = int(np.abs(offsets).max())
    nx, ny = heights.shape
    hp = np.pad(heights, r, mode="edge")
    sp = np.pad(solid, r, constant_values=False)
    sums = np.zeros((9, nx, ny))  # w, w dx, w dy, w dx^2, w dy^2, w dx dy, w dh, w dh dx, w dh dy
    for dx, dy in offsets:
        dh = hp[r + dx:r + dx + nx, r + dy:r + dy + ny] - heights
        w = sp[r + dx:r + dx + nx, r + dy:r + dy + ny] & (np.abs(dh) <= same_surface)
        wdh = np.where(w, dh, 0.0)
        sums[0] += w
        sums[1] += w * dx
        sums[2] += w * dy
        sums[3] += w * dx * dx
        sums[4] += w * dy * dy
        sums[5] += w * dx * dy
        sums[6] += wdh
        sums[7] += wdh * dx
        sums[8] += wdh * dy
    w, x, y, xx, yy, xy, h, hx, hy = sums
    normal = np.stack([np.stack([w, x, y], -1), np.stack([x, xx, xy], -1), np.stack([y, xy, yy], -1)], -2)
    normal += 1e-6 * np.eye(3)
    plane = np.linalg.solve(normal, np.stack([h, hx, hy], -1)[..., None])[..., 0]
    return np.hypot(plane[..., 1], plane[..., 2])


def _line_offsets(max_cells: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every straight move of 1..max_cells cells (centre distance) and the cells under it.

    Returns ``moves [M, 2]``, ``under [M, K, 2]`` (offsets of the cells strictly between the ends, padded with
    zeros), ``valid [M, K]`` (which of them are real) and ``step [M]`` (length of line per cell under it, in cells).
    """
    moves = [m for m in _disc_offsets(max_cells) if m.any()]
    n = np.array([max(abs(dx), abs(dy)) for dx, dy in moves])
    width = max(int(n.max()) - 1, 1)
    under = np.zeros((len(moves), width, 2), dtype=np.int64)
    valid = np.zeros((len(moves), width), dtype=bool)
    for i, ((dx, dy), steps) in enumerate(zip(moves, n)):
        k = np.arange(1, steps)
        under[i, :steps - 1] = np.stack([np.rint(dx * k / steps), np.rint(dy * k / steps)], axis=1)
        valid[i, :steps - 1] = True
    moves = np.array(moves, dtype=np.int64)
    return moves, under, valid, np.hypot(moves[:, 0], moves[:, 1]) / n


class _TileGraph:
    """Walking regions of one tile and the directed step-down / jump links between them."""

    def __init__(self, heights: np.ndarray, hs: float, wall_cells: int, reach: Go1Reach):
        self.heights = heights.astype(np.float64)
        self.hs = hs
        self.reach = reach
        nx, ny = heights.shape
        inside = np.zeros((nx, ny), dtype=bool)
        inside[wall_cells:nx - wall_cells, wall_cells:ny - wall_cells] = True
        self.solid = inside & (self.heights >= reach.pit_height)
        self.support = _disc_offsets(reach.support_radius / hs)
        slope = _slope(self.heights, self.solid, reach.slope_radius / hs, reach.max_step_up)
        self.standable = _shifted_all(self.solid, self.support, outside=False) & (slope <= reach.max_slope * hs)
        wall_band = ~_shifted_all(inside, self.support, outside=False)
        self.obstacle = inside & ~wall_band & ~self.standable
        self.labels = _regions(self.standable, self.heights, reach.max_step_up)
        self.links: dict[int, set[int]] = {}
        self._link()

    def _link(self, chunk: int = 48) -> None:
        labels, h, reach = self.labels, self.heights, self.reach
        nx, ny = labels.shape
        # Take-off cells: standable cells next to another region or to ground that cannot be stood on (a pit, an
        # edge, a steep stretch), but not those that only face the band along the tile walls.
        padded = np.pad(labels, 1, constant_values=-1)
        blocked = np.pad(self.obstacle, 1, constant_values=False)
        border = np.zeros_like(self.standable)
        for ox in (-1, 0, 1):
            for oy in (-1, 0, 1):
                nb = padded[1 + ox:1 + ox + nx, 1 + oy:1 + oy + ny]
                border |= ((nb >= 0) & (nb != labels)) | blocked[1 + ox:1 + ox + nx, 1 + oy:1 + oy + ny]
        ax, ay = np.nonzero(self.standable & border)
        if len(ax) == 0:
            return
        la, ha = labels[ax, ay][:, None], h[ax, ay][:, None]
        max_gap_cells = reach.max_gap / self.hs
        moves, under, valid, step = _line_offsets((reach.max_gap + 2 * reach.support_radius) / self.hs + 1)
        order = np.argsort(np.hypot(moves[:, 0], moves[:, 1]), kind="stable")
        moves, under, valid, step = moves[order], under[order], valid[order], step[order]
        num_labels = nx * ny
        linked = np.zeros(0, dtype=np.int64)
        for lo in range(0, len(moves), chunk):
            mv = moves[lo:lo + chunk]
            bx, by = ax[:, None] + mv[None, :, 0], ay[:, None] + mv[None, :, 1]
            ok = (bx >= 0) & (bx < nx) & (by >= 0) & (by < ny)
            bx, by = np.clip(bx, 0, nx - 1), np.clip(by, 0, ny - 1)
            lb, dh = labels[bx, by], h[bx, by] - ha
            ok &= (lb >= 0) & (lb != la) & (dh <= reach.max_step_up) & (dh >= -reach.max_step_down)
            e, m = np.nonzero(ok)
            if len(e) == 0:
                continue
            key = la[e, 0] * num_labels + lb[e, m]
            fresh = ~np.isin(key, linked)
            e, m, key = e[fresh], m[fresh], key[fresh]
            if len(e) == 0:
                continue
            un, va = under[lo + m], valid[lo + m]
            cx = np.clip(ax[e, None] + un[:, :, 0], 0, nx - 1)
            cy = np.clip(ay[e, None] + un[:, :, 1], 0, ny - 1)
            top = np.maximum(ha[e, 0], h[bx[e, m], by[e, m]]) + reach.jump_clearance
            good = np.where(va, h[cx, cy], -np.inf).max(axis=1) <= top
            good &= (~self.solid[cx, cy] & va).sum(axis=1) * step[lo + m] <= max_gap_cells + 1e-9
            linked = np.union1d(linked, key[good])
        for key in linked:
            self.links.setdefault(int(key // num_labels), set()).add(int(key % num_labels))

    def closure(self, start: set[int]) -> set[int]:
        """Every region reachable from ``start`` by walking, stepping down and jumping."""
        seen, todo = set(start), list(start)
        while todo:
            for nxt in self.links.get(todo.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        return seen

    def _window(self, x: float, y: float, radius: float) -> tuple[slice, slice, np.ndarray]:
        cx, cy, r = x / self.hs, y / self.hs, radius / self.hs
        nx, ny = self.labels.shape
        x0, x1 = max(int(np.floor(cx - r)), 0), min(int(np.ceil(cx + r)) + 1, nx)
        y0, y1 = max(int(np.floor(cy - r)), 0), min(int(np.ceil(cy + r)) + 1, ny)
        x1, y1 = max(x1, x0), max(y1, y0)
        gx, gy = np.mgrid[x0:x1, y0:y1]
        return slice(x0, x1), slice(y0, y1), (gx - cx) ** 2 + (gy - cy) ** 2 <= r**2 + 1e-9

    def regions_near(self, x: float, y: float, radius: float) -> set[int]:
        """Regions with a standable cell within ``radius`` metres of tile point ``(x, y)``."""
        sx, sy, disc = self._window(x, y, radius)
        window = self.labels[sx, sy][disc]
        return set(window[window >= 0].tolist())

    def on_surface(self, x: float, y: float, regions: set[int]) -> bool:
        """The nearest cell is solid and has standable ground of ``regions`` within ``support_radius`` at a step's
        height."""
        a, b = int(np.rint(x / self.hs)), int(np.rint(y / self.hs))
        nx, ny = self.solid.shape
        if not (0 <= a < nx and 0 <= b < ny and self.solid[a, b]):
            return False
        sx, sy, disc = self._window(a * self.hs, b * self.hs, self.reach.support_radius)
        near = disc & (np.abs(self.heights[sx, sy] - self.heights[a, b]) <= self.reach.max_step_up)
        labels = self.labels[sx, sy][near]
        return bool(set(labels[labels >= 0].tolist()) & regions)


def check_tile(terrain: Terrain, row: int, col: int, reach: Go1Reach | None = None) -> TileReport:
    """Check one tile of ``terrain`` (see the module docstring)."""
    reach = reach or Go1Reach()
    cfg = terrain.config
    hs = cfg.horizontal_scale
    graph = _TileGraph(terrain.tile_heights(row, col), hs, int(round(cfg.wall_width / hs)), reach)
    base = np.array([row * cfg.tile_length, col * cfg.tile_width])
    goals = terrain.goals[row, col, :, :2].astype(np.float64) - base
    spawn = terrain.tile_origins[row, col, :2].astype(np.float64) - base
    current = graph.closure(graph.regions_near(*spawn, hs))
    on_surface = tuple(graph.on_surface(x, y, current) for x, y in goals)
    reached = 0
    for x, y in goals:
        hit = graph.regions_near(x, y, reach.reach_radius) & current
        if not hit:
            break
        current = graph.closure(hit)
        reached += 1
    name = cfg.columns[col]
    d = float(terrain.difficulty[row, col])
    return TileReport(name, row, col, d, terrain_spec(name).effective_difficulty(d), on_surface, reached)


def check_terrain(terrain: Terrain, reach: Go1Reach | None = None) -> list[TileReport]:
    """Check every tile, column by column."""
    cfg = terrain.config
    return [check_tile(terrain, i, j, reach) for j in range(cfg.num_cols) for i in range(cfg.num_rows)]


@dataclass(frozen=True)
class TerrainSummary:
    """Per terrain: whether its difficulty-0 tiles pass and up to which difficulty every tile passes."""

    terrain: str
    passes_at_zero: bool | None
    """None when the grid has no difficulty-0 tile of this terrain."""
    traversable_up_to: float | None
    """Largest difficulty d such that every tile with difficulty <= d passes (None: already fails at the lowest)."""
    failures: tuple[TileReport, ...]


def summarise(reports: list[TileReport]) -> list[TerrainSummary]:
    """Group tile reports by terrain, in task-id order."""
    out = []
    for name in TERRAIN_NAMES:
        mine = sorted((r for r in reports if r.terrain == name), key=lambda r: (r.difficulty, r.col))
        if not mine:
            continue
        zero = [r for r in mine if r.difficulty == 0.0]
        up_to = None
        for d in sorted({r.difficulty for r in mine}):
            if not all(r.traversable for r in mine if r.difficulty == d):
                break
            up_to = d
        out.append(TerrainSummary(name, all(r.traversable for r in zero) if zero else None, up_to,
                                  tuple(r for r in mine if not r.traversable)))
    return out


def format_report(summaries: list[TerrainSummary]) -> str:
    """A plain-text table: terrain, d = 0 verdict, traversable up to, failing rows with their first reason."""
    lines = [f"{'terrain':34s} {'d=0':4s} {'ok up to d':>10s}  failing tiles (row: d_eff, reason)"]
    for s in summaries:
        zero = "-" if s.passes_at_zero is None else ("yes" if s.passes_at_zero else "NO")
        up_to = "none" if s.traversable_up_to is None else f"{s.traversable_up_to:.2f}"
        fails = "; ".join(f"row {r.row}: {r.effective_difficulty:+.2f}, {r.reason}" for r in s.failures[:3])
        more = f"; +{len(s.failures) - 3} more" if len(s.failures) > 3 else ""
        lines.append(f"{s.terrain:34s} {zero:4s} {up_to:>10s}  {fails}{more}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Check that a Go1 can follow every Parkour tile's waypoints.")
    parser.add_argument("--easy", action="store_true", help="difficulty 0 on every row (Parkour-easy)")
    parser.add_argument("--rows", type=int, default=10)
    parser.add_argument("--columns", default=None, help="comma-separated terrain names (default: all 21)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    columns = tuple(c.strip() for c in args.columns.split(",")) if args.columns else TERRAIN_NAMES
    terrain = generate_terrain(TerrainConfig(columns=columns, num_rows=args.rows, easy=args.easy, seed=args.seed))
    limits = Go1Reach()
    print("limits: " + ", ".join(f"{k} {v:g}{'' if k == 'max_slope' else ' m'}" for k, v in vars(limits).items()))
    print(format_report(summarise(check_terrain(terrain, limits))))


if __name__ == "__main__":
    main()
