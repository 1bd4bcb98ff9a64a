"""The named Parkour settings (MTBench ``final_go1_{easy,hard,hard_cl}.yaml`` and the flat pre-training) and
:func:`make_parkour_env`, which ``mtbench.envs.make_env`` calls for them.

| setting | columns (tasks) | difficulty | curriculum |
|---|---|---|---|
| ``parkour_flat`` | 21 flat columns (task ``flat`` only) | 0 | no |
| ``parkour_easy`` | the 21 terrains | 0 on every row | no |
| ``parkour_hard`` | the 21 terrains | row ``i`` of 10: ``i / 9`` | no |
| ``parkour_hard_cl`` | the 21 terrains | row ``i`` of 10: ``i / 9`` | yes (``curriculum.py``) |

``parkour_flat`` is the original's pre-training grid (``final_go1_easy`` with ``task_id=[20]``: every column flat);
its worlds carry task id 20 in the 21-slot one-hot, so a network keeps its shapes between flat pre-training and the
21-task stage. A list of terrain names (or one name) builds its own setting with those columns, ``parkour_hard``
style.
"""

from __future__ import annotations

import inspect
from typing import Any, Sequence

import torch

from .terrains import TERRAIN_NAMES

# name -> (columns, easy, curriculum)
SETTINGS: dict[str, tuple[tuple[str, ...], bool, bool]] = {
    "parkour_flat": (("flat",) * len(TERRAIN_NAMES), True, False),
    "parkour_easy": (TERRAIN_NAMES, True, False),
    "parkour_hard": (TERRAIN_NAMES, False, False),
    "parkour_hard_cl": (TERRAIN_NAMES, False, True),
}


def make_parkour_env(
    name: str | Sequence[str],
    num_envs: int | None = None,
    device: torch.device | str | None = None,
    *,
    num_rows: int = 10,
    terrain_seed: int = 0,
    easy: bool | None = None,
    curriculum: bool | None = None,
    terrain_config: dict[str, Any] | None = None,
    **overrides: Any,
):
    """Build a Parkour env.

    Args:
        name: a setting of :data:`SETTINGS`, one terrain name, or a list of terrain names (one column each; any
            subset, order or repeats of ``TERRAIN_NAMES``).
        num_envs: total worlds, split evenly over the columns (default: one per column).
        device: torch device (default: ``cuda`` if available, else ``cpu``).
        num_rows: difficulty rows of the terrain grid (10; fewer for a small CPU grid).
        terrain_seed: the terrain's seed (0: the original's per-tile seeds).
        easy: draw every tile at difficulty 0 (default: the setting's).
        curriculum: the hard-cl terrain curriculum (default: the setting's).
        terrain_config: further ``TerrainConfig`` fields (``tile_length``, ``roughness``, ...).
        **overrides: forwarded to :class:`~mtbench.envs.parkour.env.ParkourEnv` (``seed``, ``episode_length``,
            ``terrain_collision``, ``terrain_representation``, ``domain_randomization``, ``push_robots``, ...).
    """
    from .env import ParkourEnv
    from .terrain import TerrainConfig, generate_terrain

    if isinstance(name, str) and name in SETTINGS:
        columns, default_easy, default_curriculum = SETTINGS[name]
    else:
        columns = (name,) if isinstance(name, str) else tuple(name)
        if not columns:
            raise ValueError("the terrain list is empty")
        unknown = [c for c in columns if c not in TERRAIN_NAMES]
        if unknown:
            raise ValueError(f"unknown parkour names {unknown}; valid choices: {sorted(SETTINGS)} or terrain names "
                             f"{list(TERRAIN_NAMES)}")
        default_easy, default_curriculum = False, False
    accepted = set(inspect.signature(ParkourEnv.__init__).parameters) - {"self", "terrain", "num_envs", "device"}
    unknown_overrides = sorted(set(overrides) - accepted)
    if unknown_overrides:
        valid = sorted(accepted | {"num_rows", "terrain_seed", "easy", "curriculum", "terrain_config"})
        raise ValueError(f"unknown Parkour env overrides {unknown_overrides}; valid: {valid}")
    if num_envs is not None and not isinstance(num_envs, int):
        raise ValueError(f"parkour settings take a total num_envs (an int, split over the {len(columns)} columns), "
                         f"got {num_envs!r}")
    if device is None:
        device = "cuda" if torch.cuda.is_available() else "cpu"
    config = TerrainConfig(columns=tuple(columns), num_rows=num_rows, seed=terrain_seed,
                           easy=default_easy if easy is None else bool(easy), **(terrain_config or {}))
    terrain = generate_terrain(config)
    return ParkourEnv(terrain, len(columns) if num_envs is None else num_envs, device=device,
                      curriculum=default_curriculum if curriculum is None else bool(curriculum), **overrides)
