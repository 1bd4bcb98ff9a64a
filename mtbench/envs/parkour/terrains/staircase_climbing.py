"""Pit crossed by six tall, deep steps up (climbing rather than walking), ending on a plateau."""

from __future__ import annotations

import numpy as np

from ._tile import Tile
from .staircase_walking import _staircase

TASK_ID = 15
DIFFICULTY_RANGE = (0.0, 0.6)


def generate(rng: np.random.RandomState, d: float, tile: Tile) -> np.ndarray:
    """Tread ``1.5 - 0.1d`` m, width ``1.5 - 0.4d`` m, rise ``U(0.3 + 0.3d, 0.4 + 0.3d)`` m per step; the ground after
    the last step stays at the top height."""
    return _staircase(rng, tile, tread_m=1.5 - 0.1 * d, width_m=1.5 - 0.4 * d,
                      rise=(0.3 + 0.3 * d, 0.4 + 0.3 * d))
