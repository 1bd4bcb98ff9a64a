"""MTBench's difficulty mapping: row difficulty ``d`` in [0, 1] to the difficulty a terrain function is drawn with.

Each terrain declares the original ``DIFFICULTY_SCALING[name] = (min, max)``; the original then shifts both ends
by ``-0.2`` ("easier offset") and draws the terrain with ``d_eff = d * (max - min) + min``. The arithmetic is kept
in the original's order so that ``d_eff`` equals the original's bit for bit. A terrain with ``None`` (the spiral
staircase, which never calls the scaling, and flat, which ignores difficulty) is drawn with the raw ``d``.
"""

from __future__ import annotations

EASIER_OFFSET = 0.2
"""Subtracted from both ends of every terrain's (min, max) range."""


def shifted_range(difficulty_range: tuple[float, float]) -> tuple[float, float]:
    """The (min, max) a terrain is actually scaled with: both ends of the declared range minus 0.2."""
    lo, hi = difficulty_range
    return lo - EASIER_OFFSET, hi - EASIER_OFFSET


def scale_difficulty(d: float, difficulty_range: tuple[float, float] | None) -> float:
    """``d * (max - min) + min`` over the shifted range, or ``d`` itself when the terrain has no range."""
    if difficulty_range is None:
        return d
    lo, hi = shifted_range(difficulty_range)
    return d * (hi - lo) + lo
