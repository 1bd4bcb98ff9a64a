"""The Parkour-hard-cl terrain curriculum (MTBench ``_update_terrain_curriculum``, goal-based "soft variant").

At every reset after the first, a world's level (its row of the terrain grid) moves up one row if it reached at
least ``0.8 * num_goals`` goals (7 of 8) and down one row (not below 0) if it reached fewer than
``0.4 * num_goals`` (3 or fewer); a quarter of the worlds that neither move up nor down, and every world that moved
past the last row, are sent to the random level ``floor(U * level)`` (``U`` uniform in [0, 1)), below their new one.
Initial levels are uniform integers in ``[0, min(max_init_level, num_rows - 1)]``. Pure tensor functions (no host
synchronisation), so that tests can give known answers.
"""

from __future__ import annotations

import torch

MOVE_UP_FRACTION = 0.8
MOVE_DOWN_FRACTION = 0.4
RANDOMIZE_STUCK_PROBABILITY = 0.25
MAX_INIT_LEVEL = 2


def update_levels(
    levels: torch.Tensor,
    goals_reached: torch.Tensor,
    num_goals: int,
    num_rows: int,
    u_stuck: torch.Tensor,
    u_level: torch.Tensor,
) -> torch.Tensor:
    """New levels ``[N]`` (long) of worlds that finished an episode.

    Args:
        levels: current levels ``[N]`` (long).
        goals_reached: goals reached in the finished episode ``[N]`` (``cur_goal_idx``).
        num_goals: goals per tile (8).
        num_rows: rows of the terrain grid (levels ``0 .. num_rows - 1``).
        u_stuck: uniform draws ``[N]`` in [0, 1): a world that does not move is randomized when ``u_stuck < 0.25``.
        u_level: uniform draws ``[N]`` in [0, 1) for the random level ``floor(u_level * level)``.
    """
    reached = goals_reached.float()
    move_up = reached >= MOVE_UP_FRACTION * num_goals
    move_down = reached < MOVE_DOWN_FRACTION * num_goals
    stuck = ~(move_up | move_down)
    new = torch.clamp(levels + move_up.long() - move_down.long(), min=0)
    randomize = (new >= num_rows) | (stuck & (u_stuck < RANDOMIZE_STUCK_PROBABILITY))
    random_level = torch.floor(u_level * new.float()).long()
    return torch.where(randomize, random_level, new)


def initial_levels(n: int, num_rows: int, generator: torch.Generator, device: torch.device | str,
                   max_init_level: int = MAX_INIT_LEVEL) -> torch.Tensor:
    """Uniform initial levels ``[n]`` in ``[0, min(max_init_level, num_rows - 1)]``."""
    top = min(max_init_level, num_rows - 1)
    return torch.randint(0, top + 1, (n,), generator=generator, device=device)
