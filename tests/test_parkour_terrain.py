"""Tests for the Parkour terrain (mtbench.envs.parkour: terrains/, terrain.py, traversability.py, render_terrain.py).

The strongest check compares every terrain function with the original MTBench code (ed2e2b5), read from a git
mirror of Viraj-Joshi/MTBench when one is available (``MTBENCH_ORIGINAL_REPO``, default the workspace mirror) and
run under a stand-in ``isaacgym`` module: heights, goals and the random stream must agree bit for bit. The other
tests assert known answers (difficulty mapping, seeds, layout, walls) and invariants of the generated grid.
"""

from __future__ import annotations

import dataclasses
import importlib.machinery
import os
import subprocess
import sys
import time
import types
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from mtbench.envs.parkour import TERRAIN_NAMES, Terrain, TerrainConfig, generate_terrain
from mtbench.envs.parkour.terrain import roughness_units
from mtbench.envs.parkour.terrains import TERRAINS, Tile, scale_difficulty, terrain_spec
from mtbench.envs.parkour.traversability import Go1Reach, check_tile, summarise, check_terrain

CANONICAL = (
    "jump_on_and_off_box", "forward_ramp_lips", "sphere_bump_lips", "forward_ramp_no_lips", "flush_a_frame",
    "sphere_bump", "box_jump_even", "box_jump_uneven", "flat_circle_jump", "bump_jump", "sideways_ramp",
    "stepping_stones_cylinder", "stepping_stones_randomly_arranged", "staircase_walking_full_width",
    "staircase_walking", "staircase_climbing", "staircase_spiral", "squeeze", "agility_poles", "balance_beam", "flat",
)
# The original's DIFFICULTY_SCALING before the -0.2 shift (None: the terrain is drawn with the raw d).
ORIGINAL_RANGES = {
    "jump_on_and_off_box": (0.1, 0.8), "forward_ramp_lips": (0.6, 1), "sphere_bump_lips": (0.2, 1.1),
    "forward_ramp_no_lips": (0.4, 0.8), "flush_a_frame": (0.55, 0.9), "sphere_bump": (0.3, 1),
    "box_jump_even": (-0.1, 0.6), "box_jump_uneven": (-0.2, 0.8), "flat_circle_jump": (0.1, 1),
    "bump_jump": (-0.3, 0.7), "sideways_ramp": (0.2, 1.1), "stepping_stones_cylinder": (-0.2, 1.1),
    "stepping_stones_randomly_arranged": (0.3, 0.5), "staircase_walking_full_width": (0.1, 0.9),
    "staircase_walking": (0, 1.2), "staircase_climbing": (0.0, 0.6), "staircase_spiral": None, "squeeze": (0, 1),
    "agility_poles": (0, 1), "balance_beam": (0.5, 1), "flat": None,
}
PIT = -0.5  # anything below is pit
ROUGH = 0.04 + 0.005  # largest roughness amplitude plus one quantisation step


@lru_cache(maxsize=None)
def grid(easy: bool = False, seed: int = 0) -> Terrain:
    return generate_terrain(TerrainConfig(easy=easy, seed=seed))


def draw(name: str, d: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """One default-size tile of ``name`` at row difficulty ``d`` without roughness: (heights m, goals in cells)."""
    spec = TERRAINS[name]
    tile = Tile.empty(360, 80, 0.05)
    goals = spec.generate(np.random.RandomState(seed), spec.effective_difficulty(d), tile)
    return tile.heights, goals


def tiles(terrain: Terrain) -> np.ndarray:
    """All tiles' heights as ``[rows, cols, 360, 80]`` (a view)."""
    b = terrain.config.border_cells
    inner = terrain.heights[b:-b, b:-b]
    return inner.reshape(terrain.config.num_rows, 360, terrain.config.num_cols, 80).transpose(0, 2, 1, 3)


def local_goals(terrain: Terrain, i: int, j: int) -> np.ndarray:
    cfg = terrain.config
    return terrain.goals[i, j] - np.array([i * cfg.tile_length, j * cfg.tile_width, 0.0], dtype=np.float32)


# ----------------------------------------------------------------------------------------------- registry, mapping


def test_registry_is_the_canonical_mtbench_order_with_the_original_ranges():
    assert TERRAIN_NAMES == CANONICAL
    assert [TERRAINS[n].task_id for n in TERRAIN_NAMES] == list(range(21))
    for name, spec in TERRAINS.items():
        assert spec.difficulty_range == ORIGINAL_RANGES[name], name
        assert spec.summary and spec.generate.__doc__, name
    with pytest.raises(ValueError, match="valid choices"):
        terrain_spec("parkour_box")


@pytest.mark.parametrize("name, d, expected", [
    ("jump_on_and_off_box", 0.0, 0.1 - 0.2), ("jump_on_and_off_box", 1.0, 0.8 - 0.2),
    ("jump_on_and_off_box", 0.5, 0.5 * 0.7 - 0.1), ("bump_jump", 0.0, -0.5), ("bump_jump", 1.0, 0.5),
    ("stepping_stones_randomly_arranged", 0.5, 0.2), ("balance_beam", 0.0, 0.3),
    ("staircase_spiral", 0.7, 0.7), ("flat", 0.3, 0.3),
])
def test_effective_difficulty_known_answers(name, d, expected):
    assert terrain_spec(name).effective_difficulty(d) == pytest.approx(expected, abs=1e-12)
    assert scale_difficulty(d, ORIGINAL_RANGES[name]) == terrain_spec(name).effective_difficulty(d)


def test_jump_on_and_off_box_heights_at_difficulty_zero():
    """d = 0 -> d_eff = 0.1 - 0.2 = -0.1: box i is U(0.1 + 0.55 d_eff, 0.15 + 0.55 d_eff) + 0.05 i = [0.045, 0.095]
    + 0.05 i high; grid heights are truncated to 5 mm steps, roughness is at most 4 cm."""
    d_eff = -0.1
    for seed in range(5):
        heights, goals = draw("jump_on_and_off_box", 0.0, seed)
        for i in range(6):
            x, y = goals[i + 1]
            top = heights[int(x), int(y)]
            assert 0.1 + 0.55 * d_eff + 0.05 * i <= top <= 0.15 + 0.55 * d_eff + 0.05 * i
    terrain = grid()
    j = TERRAIN_NAMES.index("jump_on_and_off_box")
    tops = local_goals(terrain, 0, j)[1:7, 2]
    lo = 0.045 + 0.05 * np.arange(6) - 0.005 - 0.04
    hi = 0.095 + 0.05 * np.arange(6) + 0.04
    assert np.all((tops >= lo) & (tops <= hi)), tops


def test_reported_difficulty_is_the_row_difficulty_and_zero_when_easy():
    np.testing.assert_allclose(grid().difficulty, np.repeat(np.arange(10)[:, None] / 9, 21, axis=1), atol=1e-7)
    assert np.all(grid(easy=True).difficulty == 0)
    single = generate_terrain(TerrainConfig(columns=("flat",), num_rows=1))
    assert single.difficulty[0, 0] == 0.5  # the original's choice for a single row


# ----------------------------------------------------------------------------------------- seeds and determinism


def test_tile_seeds_follow_the_original_formula():
    cfg = TerrainConfig()
    assert cfg.tile_seed(0, 0) == 0
    assert cfg.tile_seed(0, 1) == 47  # int(1 / 21 * 1e3)
    assert cfg.tile_seed(9, 20) == int(20 / 21 * 1e3 + 1e6)
    assert cfg.tile_seed(3, 5) == int(5 / 21 * 1e3 + 3 / 9 * 1e6)


def test_seed_zero_tile_is_the_terrain_function_with_the_original_seed_plus_roughness_and_walls():
    terrain = grid()
    i, j = 4, TERRAIN_NAMES.index("box_jump_uneven")
    rng = np.random.RandomState(int(j / 21 * 1e3 + i / 9 * 1e6))
    spec = TERRAINS["box_jump_uneven"]
    tile = Tile.empty(360, 80, 0.05)
    spec.generate(rng, spec.effective_difficulty(i / 9), tile)
    units = (tile.heights / 0.005).astype(np.int16) + roughness_units(rng, 360, 80, terrain.config)
    units[:2], units[-2:], units[:, :2], units[:, -2:] = 99, 99, 99, 99
    np.testing.assert_array_equal(terrain.tile_heights(i, j), (units * 0.005).astype(np.float32))


def test_generation_is_deterministic_and_the_seed_changes_it():
    cfg = TerrainConfig(columns=("flat", "box_jump_even"), num_rows=3)
    a, b = generate_terrain(cfg), generate_terrain(cfg)
    for field in ("heights", "tile_origins", "goals", "difficulty", "task_ids"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    c = generate_terrain(dataclasses.replace(cfg, seed=7))
    flat_a, flat_c = a.tile_heights(1, 0)[2:-2, 2:-2], c.tile_heights(1, 0)[2:-2, 2:-2]
    assert not np.array_equal(flat_a, flat_c)  # different roughness
    assert np.abs(flat_c).max() <= ROUGH


# -------------------------------------------------------------------------------------------------- roughness


def test_roughness_is_bilinear_interpolation_of_coarse_uniform_levels():
    scipy_interpolate = pytest.importorskip("scipy.interpolate")
    cfg = TerrainConfig()
    rng_a, rng_b = np.random.RandomState(3), np.random.RandomState(3)
    got = roughness_units(rng_a, 360, 80, cfg)
    amplitude = rng_b.uniform(0.02, 0.04)
    levels = np.arange(int(-amplitude / 0.005), int(amplitude / 0.005) + 1)
    coarse = rng_b.choice(levels, (240, 53))  # int(18 / 0.075), int(4 / 0.075)
    interp = scipy_interpolate.RegularGridInterpolator((np.linspace(0, 18, 240), np.linspace(0, 4, 53)), coarse)
    fx, fy = np.meshgrid(np.linspace(0, 18, 360), np.linspace(0, 4, 80), indexing="ij")
    expected = interp(np.stack([fx, fy], -1))
    assert np.abs(got - expected).max() <= 0.5 + 1e-9  # rounding to whole units
    assert np.mean(got == np.rint(expected)) > 0.99  # differs only where float rounding straddles .5
    assert got.min() >= levels.min() and got.max() <= levels.max()
    assert 4 <= levels.max() <= 8


def test_flat_stays_flat_within_the_roughness():
    terrain = grid()
    j = TERRAIN_NAMES.index("flat")
    for i in range(10):
        inside = terrain.tile_heights(i, j)[2:-2, 2:-2]
        assert np.abs(inside).max() <= ROUGH
        assert inside.std() > 0.005  # the roughness is there


# ------------------------------------------------------------------------------------------ per-terrain geometry


def _pit_gaps(h: np.ndarray, goals: np.ndarray) -> float:
    """Mean number of pit cells on the straight lines between consecutive obstacle goals 1..6."""
    gaps = []
    for k in range(1, 6):
        (ax, ay), (bx, by) = goals[k], goals[k + 1]
        n = int(abs(bx - ax)) + 1
        xs = np.linspace(ax, bx, n).astype(int)
        ys = np.rint(np.linspace(ay, by, n)).astype(int)
        gaps.append(np.sum(h[xs, ys] < PIT))
    return float(np.mean(gaps))


def _opening(h: np.ndarray, x: float, y: float) -> int:
    """Cells of the free run (below wall height) across the tile through (x, y)."""
    row = h[int(x)] < 0.35
    a = b = int(y)
    while a > 0 and row[a - 1]:
        a -= 1
    while b < len(row) - 1 and row[b + 1]:
        b += 1
    return b - a + 1


def _stone_cells(h: np.ndarray, goals: np.ndarray) -> int:
    """Solid cells after the spawn zone, not counting whole solid rows (the ground after the stones)."""
    after = h[40:] > PIT
    return int(after.sum() - after.all(axis=1).sum() * h.shape[1])


def _pole_spacing(h: np.ndarray, goals: np.ndarray) -> float:
    xs = np.nonzero(h[:, 40] > 0.5)[0]
    starts = xs[np.r_[True, np.diff(xs) > 1]]
    return float(np.mean(np.diff(starts)))


# terrain -> (measure(heights, goals), +1 if it grows with difficulty, -1 if it shrinks)
MEASURES = {
    "jump_on_and_off_box": (lambda h, g: h.max(), +1),  # box height
    "forward_ramp_lips": (lambda h, g: h.max(), +1),  # lip + rise
    "sphere_bump_lips": (lambda h, g: h.max(), +1),  # bump height
    "forward_ramp_no_lips": (lambda h, g: h.max(), +1),  # ramp top
    "flush_a_frame": (lambda h, g: h.max(), +1),  # peak
    "sphere_bump": (lambda h, g: h.max(), +1),  # bump height
    "box_jump_even": (_pit_gaps, +1),  # gap length
    "box_jump_uneven": (_pit_gaps, +1),  # gap length
    "flat_circle_jump": (_pit_gaps, +1),  # gap between pillars
    "bump_jump": (lambda h, g: float(np.mean(np.diff(g[1:7, 0]))), +1),  # dome spacing
    "sideways_ramp": (lambda h, g: h.max(), +1),  # platform height
    "stepping_stones_cylinder": (_stone_cells, -1),  # stone size
    "stepping_stones_randomly_arranged": (_stone_cells, -1),  # stone size
    "staircase_walking_full_width": (lambda h, g: h.max(), +1),  # rises
    "staircase_walking": (lambda h, g: h.max(), +1),  # rises
    "staircase_climbing": (lambda h, g: h.max(), +1),  # rises
    "staircase_spiral": (lambda h, g: h.max(), +1),  # rises
    "squeeze": (lambda h, g: float(np.mean([_opening(h, x, y) for x, y in g[1:7]])), -1),  # opening
    "agility_poles": (_pole_spacing, -1),  # pole spacing
    "balance_beam": (lambda h, g: int(np.sum(h[int(g[3, 0])] > PIT)), -1),  # beam width
}


@pytest.mark.parametrize("name", [n for n in CANONICAL if n != "flat"])
def test_obstacles_scale_with_difficulty(name):
    measure, sign = MEASURES[name]
    values = [np.mean([measure(*draw(name, d, seed)) for seed in range(6)]) for d in (0.0, 0.5, 1.0)]
    assert sign * (values[1] - values[0]) > 0 and sign * (values[2] - values[1]) > 0, values


@pytest.mark.parametrize("name", ["box_jump_even", "box_jump_uneven", "sideways_ramp", "flat_circle_jump",
                                  "bump_jump", "stepping_stones_cylinder", "stepping_stones_randomly_arranged",
                                  "staircase_walking", "staircase_climbing", "balance_beam"])
def test_pit_terrains_are_pits_after_the_spawn_zone(name):
    """(staircase_walking_full_width also lowers the ground to the pit, but its full-width steps cover all of it.)"""
    heights, goals = draw(name, 0.5, 1)
    assert np.all(heights[:40] > PIT)
    assert np.mean(heights[40:int(goals[6, 0])] < PIT) > 0.4  # most of the obstacle stretch is pit


def test_six_obstacles_where_the_original_has_them():
    heights, goals = draw("jump_on_and_off_box", 0.3, 2)
    assert len([r for r in np.split(heights[:, 40] > 0.02, np.nonzero(np.diff(heights[:, 40] > 0.02))[0] + 1)
                if r[0]]) == 6
    heights, _ = draw("agility_poles", 0.3, 0)
    assert int(np.sum(np.diff((heights[:, 40] > 0.5).astype(int)) == 1)) == 6
    heights, goals = draw("squeeze", 0.3, 0)
    assert len({int(x) for x, _ in goals[1:7]}) == 6 and np.all(heights.max(axis=1)[int(goals[6, 0])] == 0.7)


# ------------------------------------------------------------------------------------------ grid layout, walls


def test_grid_layout_and_spawn_origins():
    terrain = grid()
    assert terrain.heights.shape == (10 * 360 + 200, 21 * 80 + 200) and terrain.heights.dtype == np.float32
    np.testing.assert_array_equal(terrain.task_ids, np.arange(21))
    units = terrain.heights / 0.005
    np.testing.assert_allclose(units, np.rint(units), atol=1e-3)  # quantised to vertical_scale
    assert np.all(terrain.heights[:100] == 0) and np.all(terrain.heights[:, -100:] == 0)  # flat border
    i, j = np.meshgrid(np.arange(10), np.arange(21), indexing="ij")
    np.testing.assert_allclose(terrain.tile_origins[..., 0], i * 18 + 1.0)
    np.testing.assert_allclose(terrain.tile_origins[..., 1], (j + 0.5) * 4)
    assert np.all(np.abs(terrain.tile_origins[..., 2]) <= ROUGH)
    # height_at: world (0, 0) is the corner cell of tile (0, 0); off-grid points take the nearest edge cell
    assert terrain.height_at(0.0, 0.0) == terrain.heights[100, 100]
    assert terrain.height_at(18.0 + 0.05 * 7, 4.0 * 3 + 0.05 * 11) == terrain.tile_heights(1, 3)[7, 11]
    assert terrain.height_at(-100.0, 1e4) == terrain.heights[0, -1]
    np.testing.assert_array_equal(terrain.height_at(terrain.tile_origins[..., 0], terrain.tile_origins[..., 1]),
                                  terrain.heights[100 + i * 360 + 20, 100 + j * 80 + 40])


def test_walls_on_every_tile_edge():
    """0.1 m (2 cells) at 0.495 m (99 units) on all four edges of every tile, set after the roughness. The original
    walls are absolute heights, so they stand 0.45 m or more above spawn-level ground; a plateau (the top of a
    staircase) can be higher than the wall beside it."""
    for easy in (False, True):
        h = tiles(grid(easy))
        for band in (h[:, :, :2], h[:, :, -2:], h[:, :, :, :2], h[:, :, :, -2:]):
            assert np.all(band == np.float32(0.495))
        assert np.all(h[:, :, :2, 2:-2].min(axis=2) - h[:, :, 2, 2:-2] >= 0.45)  # start wall over the spawn ground
        assert np.all(0.495 - h[:, :, 2:40, 2:4].max(axis=(2, 3)) >= 0.45)  # side walls beside the spawn zone
        assert np.all(0.495 - h[:, :, 2:40, -4:-2].max(axis=(2, 3)) >= 0.45)


def test_spawn_zone_is_walkable():
    """The first 1.5 m (to goal 0) is spawn-level ground everywhere; the first 2 m too, except that the original's
    first flat_circle_jump pillar reaches back into it."""
    for easy in (False, True):
        h = tiles(grid(easy))
        assert np.abs(h[:, :, 2:30, 2:-2]).max() <= ROUGH
        others = [j for j, name in enumerate(TERRAIN_NAMES) if name != "flat_circle_jump"]
        assert np.abs(h[:, others, 2:40, 2:-2]).max() <= ROUGH
        assert np.abs(h[:, TERRAIN_NAMES.index("flat_circle_jump"), 2:40, 2:-2]).max() > 0.1


# ----------------------------------------------------------------------------------------------------- waypoints


@pytest.mark.parametrize("easy", [False, True])
def test_waypoints_inside_the_tiles_in_order_and_on_the_ground(easy):
    terrain = grid(easy)
    assert terrain.goals.shape == (10, 21, 8, 3)
    for j, name in enumerate(TERRAIN_NAMES):
        for i in range(10):
            g = local_goals(terrain, i, j)
            assert np.all((g[:, 0] >= 0.1) & (g[:, 0] <= 17.9) & (g[:, 1] >= 0.1) & (g[:, 1] <= 3.9)), (name, i)
            if name != "staircase_spiral":  # the spiral's goals go round the disc
                assert np.all(np.diff(g[:, 0]) > 0), (name, i)
            np.testing.assert_array_equal(terrain.goals[i, j, :, 2],
                                          terrain.height_at(terrain.goals[i, j, :, 0], terrain.goals[i, j, :, 1]))
            if name == "stepping_stones_cylinder" and terrain.difficulty[i, j] > 0.2:
                continue  # the original's pair goals fall between the shrinking stones (see traversability)
            assert np.all(g[:, 2] > PIT), (name, i)
    j = TERRAIN_NAMES.index("flat")
    g = local_goals(terrain, 0, j)
    np.testing.assert_allclose(g[:, 0], np.linspace(2, 16, 8), atol=1e-5)
    assert np.all(np.abs(g[:, 1] - 2) <= 1.0)


def test_waypoints_sit_on_the_platforms():
    """Goal k of a platform terrain has the platform's height (the drawn height plus roughness); goal 0 and the
    last goal are on spawn-level ground."""
    terrain = grid()
    for name in ("jump_on_and_off_box", "box_jump_even", "box_jump_uneven", "staircase_walking",
                 "staircase_climbing", "balance_beam"):
        j = TERRAIN_NAMES.index(name)
        for i in (0, 5, 9):
            rng = np.random.RandomState(terrain.config.tile_seed(i, j))
            tile = Tile.empty(360, 80, 0.05)
            spec = TERRAINS[name]
            goals = spec.generate(rng, spec.effective_difficulty(terrain.difficulty[i, j]), tile)
            drawn = tile.heights[np.rint(goals[:, 0]).astype(int), np.rint(goals[:, 1]).astype(int)]
            z = local_goals(terrain, i, j)[:, 2]
            assert np.all(np.abs(z - drawn) <= ROUGH), (name, i, z, drawn)
            assert np.all(drawn[1:7] > PIT)
    g = local_goals(terrain, 3, TERRAIN_NAMES.index("staircase_climbing"))
    assert np.all(np.diff(g[1:7, 2]) > 0.3 - 2 * ROUGH)  # one climbing step higher each time


def test_agility_poles_last_goal_is_kept_inside_the_tile():
    """The original puts it 0.5 m past a seventh pole: 20.05 m along an 18 m tile at d = 0."""
    heights, goals = draw("agility_poles", 0.0, 0)
    pole_starts = np.nonzero(np.diff((heights[:, 40] > 0.5).astype(int)) == 1)[0] + 1
    assert goals[7, 0] == 350 and goals[7, 0] * 0.05 > pole_starts[-1] * 0.05 + 0.3
    _, goals = draw("agility_poles", 1.0, 0)
    assert goals[7, 0] == goals[6, 0] + (22 + 6) + 10  # unchanged where the original's goal fits


# -------------------------------------------------------------------------------------------- traversability


def test_every_terrain_is_traversable_at_difficulty_zero():
    terrain = grid()
    reports = [check_tile(terrain, 0, j) for j in range(21)]
    failed = [(r.terrain, r.reason) for r in reports if not r.traversable]
    assert not failed
    assert all(s.passes_at_zero for s in summarise(reports))


def test_traversability_finds_the_original_limits():
    """Known failures: the top staircase_climbing row has 0.6-0.7 m steps, the top jump_on_and_off_box row boxes of
    0.43-0.73 m; the top stepping_stones_cylinder row's pair goals lie between the stones."""
    terrain = grid()
    climb = check_tile(terrain, 9, TERRAIN_NAMES.index("staircase_climbing"))
    assert not climb.traversable and climb.reached == 1
    assert climb.on_surface == (True,) + (False,) * 7  # the steps and the plateau cannot be got onto
    box = check_tile(terrain, 9, TERRAIN_NAMES.index("jump_on_and_off_box"))
    assert not box.traversable and box.reached < 8
    stones = check_tile(terrain, 9, TERRAIN_NAMES.index("stepping_stones_cylinder"))
    assert not stones.traversable and not any(stones.on_surface[1:7])


def _flat_terrain() -> Terrain:
    return generate_terrain(TerrainConfig(columns=("flat",), num_rows=1, roughness=(0.0, 0.0)))


def _with(terrain: Terrain, heights_fn, goals_x=None, goals_y=None) -> Terrain:
    heights = terrain.heights.copy()
    heights_fn(terrain.tile_heights(0, 0).shape, heights[terrain.tile_window(0, 0)])
    goals = terrain.goals.copy()
    goals[0, 0, :, 0] = np.linspace(1.5, 12.0, 8) if goals_x is None else goals_x
    goals[0, 0, :, 1] = 2.0 if goals_y is None else goals_y
    return dataclasses.replace(terrain, heights=heights, goals=goals)


@pytest.mark.parametrize("case, traversable", [
    ("gap_0.5m", True), ("gap_0.9m", False), ("step_0.3m", True), ("step_0.45m", False),
    ("drop_0.55m", True), ("thin_wall_1m", False), ("slope_30deg", True), ("crack_0.05m", True),
])
def test_traversability_model_on_synthetic_tiles(case, traversable):
    def edit(shape, tile):
        if case.startswith("gap"):
            width = int(round(float(case[4:-1]) / 0.05))
            tile[100:100 + width, 2:-2] = -1.0
        elif case.startswith("step"):
            tile[100:, 2:-2] = float(case[5:-1])
        elif case == "drop_0.55m":
            tile[2:100, 2:-2] = 0.55
            tile[100:, 2:-2] = 0.0
        elif case == "thin_wall_1m":
            tile[100:103, 2:-2] = 1.0
        elif case == "slope_30deg":
            tile[100:160, 2:-2] = (np.arange(60) * 0.05 * np.tan(np.radians(30)))[:, None]
            tile[160:, 2:-2] = 59 * 0.05 * np.tan(np.radians(30))
        elif case == "crack_0.05m":
            tile[100, 2:-2] = -1.0
    report = check_tile(_with(_flat_terrain(), edit), 0, 0)
    assert report.traversable == traversable, report.reason


def test_goals_in_a_pit_on_a_block_or_in_the_walls_are_not_on_a_surface():
    """Each of these goals is within the env's 0.3 m of ground the robot stands on, so it is reached, but it is not
    on a surface the robot can get onto: the edge of a pit, the top of a 0.7 m block, the tile's end wall."""
    def edit(shape, tile):
        tile[150:170, 10:30] = -1.0  # a 1 m pit beside the path
        tile[200:210, 50:60] = 0.7  # a 0.5 m block beside the path
    x = np.array([1.5, 3.0, 7.55, 10.25, 12.0, 14.0, 16.0, 17.97])
    y = np.array([2.0, 2.0, 1.0, 2.75, 2.0, 2.0, 2.0, 2.0])
    report = check_tile(_with(_flat_terrain(), edit, x, y), 0, 0)
    assert report.on_surface == (True, True, False, False, True, True, True, False)
    assert report.reached == 8 and not report.traversable
    assert report.reason == "goals 2,3,7 not on a surface"


def test_summary_reports_the_largest_traversable_difficulty():
    terrain = generate_terrain(TerrainConfig(columns=("staircase_climbing", "flat"), num_rows=10))
    summary = {s.terrain: s for s in summarise(check_terrain(terrain, Go1Reach()))}
    assert summary["flat"].traversable_up_to == 1.0 and not summary["flat"].failures
    climbing = summary["staircase_climbing"]
    assert climbing.passes_at_zero and 0.0 <= climbing.traversable_up_to < 1.0
    assert all(r.difficulty > climbing.traversable_up_to for r in climbing.failures)


# ------------------------------------------------------------------------------------------- config, speed, CLI


def test_config_validation_names_the_choices():
    with pytest.raises(ValueError, match="valid choices"):
        TerrainConfig(columns=("flat", "lava"))
    with pytest.raises(ValueError, match="num_rows"):
        TerrainConfig(num_rows=0)
    with pytest.raises(ValueError, match="roughness"):
        TerrainConfig(roughness=(0.05, 0.01))
    with pytest.raises(ValueError, match="repeated tile seeds"):
        generate_terrain(TerrainConfig(columns=("flat",) * 1001, num_rows=1))


def test_whole_grid_generates_in_a_few_seconds():
    start = time.process_time()  # CPU time: robust to other processes on the machine
    generate_terrain(TerrainConfig(seed=3))
    assert time.process_time() - start < 5.0  # about 0.2 s on a 2-core CPU (docs/parkour.md)


def test_render_grid_and_tile(tmp_path):
    from mtbench.envs.parkour import render_terrain

    render_terrain.main([str(tmp_path / "grid.png"), "--rows", "2", "--columns", "flat,squeeze", "--dpi", "40"])
    render_terrain.main([str(tmp_path / "tile.png"), "--rows", "2", "--columns", "flat,squeeze", "--tile", "1,1",
                         "--dpi", "40"])
    for name in ("grid.png", "tile.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match="outside"):
        render_terrain.render_tile(generate_terrain(TerrainConfig(columns=("flat",), num_rows=1)), 1, 0,
                                   tmp_path / "x.png")


# ------------------------------------------------------------------------- comparison with the original MTBench

ORIGINAL_COMMIT = "ed2e2b5a573c3db36e815a0521d13644f5ca8105"
ORIGINAL_PATH = "isaacgymenvs/tasks/locomotion/set_terrains/set_terrain_benchmark.py"


@lru_cache(maxsize=1)
def _original_module() -> types.ModuleType | None:
    repo = Path(os.environ.get("MTBENCH_ORIGINAL_REPO", "/work/.mirror/Viraj-Joshi+MTBench/repo"))
    try:
        source = subprocess.run(["git", "-C", str(repo), "show", f"{ORIGINAL_COMMIT}:{ORIGINAL_PATH}"],
                                capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    # The module imports isaacgym (unused by the terrain functions): a stand-in with a spec, removed afterwards.
    stub = types.ModuleType("isaacgym")
    stub.__spec__ = importlib.machinery.ModuleSpec("isaacgym", None)
    stub.terrain_utils = None
    saved = sys.modules.get("isaacgym")
    sys.modules["isaacgym"] = stub
    try:
        module = types.ModuleType("mtbench_original_terrains")
        exec(compile(source, ORIGINAL_PATH, "exec"), module.__dict__)
    finally:
        if saved is None:
            del sys.modules["isaacgym"]
        else:
            sys.modules["isaacgym"] = saved

    # The original ran on NumPy 1.x: np.bool8 existed and np.ogrid/np.mgrid over int16 bounds gave int64 grids
    # (NumPy 2 keeps int16, whose squared distances overflow). Give the module a numpy that behaves that way.
    class _Grid:
        def __init__(self, grid):
            self.grid = grid

        def __getitem__(self, key):
            key = key if isinstance(key, tuple) else (key,)
            return self.grid[tuple(slice(None if k.start is None else int(k.start), int(k.stop), k.step)
                                   for k in key)]

    numpy1 = types.ModuleType("numpy1")
    numpy1.__dict__.update(np.__dict__)
    numpy1.ogrid, numpy1.mgrid, numpy1.bool8 = _Grid(np.ogrid), _Grid(np.mgrid), np.bool_
    module.np = numpy1
    return module


@pytest.mark.parametrize("name", CANONICAL)
def test_terrain_functions_match_the_original_bit_for_bit(name):
    original = _original_module()
    if original is None:
        pytest.skip("no git mirror of Viraj-Joshi/MTBench (set MTBENCH_ORIGINAL_REPO)")
    j = CANONICAL.index(name)
    function = original.TERRAIN_FUNCTIONS[j]
    assert function.__name__ == f"set_terrain_{name}"
    for i, easy in [(0, False), (2, False), (5, False), (9, False), (7, True)]:
        seed = int(j / 21 * 1e3 + i / 9 * 1e6)
        d = 0.0 if easy else i / 9
        np.random.seed(seed)
        heights, goals = function(18.0, 4.0, 0.05, d)
        after = np.random.random_sample()
        rng = np.random.RandomState(seed)
        tile = Tile.empty(360, 80, 0.05)
        ours = TERRAINS[name].generate(rng, TERRAINS[name].effective_difficulty(d), tile)
        np.testing.assert_array_equal(tile.heights, heights)
        if name == "agility_poles":  # deliberate: our last goal stays inside the tile
            goals[7, 0] = min(goals[7, 0], 350)
        np.testing.assert_array_equal(ours, goals.astype(np.float64))
        assert rng.random_sample() == after  # same number of random draws, so the roughness matches too
