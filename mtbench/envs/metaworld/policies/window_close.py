"""Scripted window_close: push the sash handle sideways (-x); see :func:`.window_open.push_sash`."""

from __future__ import annotations

import torch

from .window_open import push_sash


def policy(obs: torch.Tensor) -> torch.Tensor:
    # handleCloseStart is 2.4 cm right of the bar; the goal is that point at the end of the travel
    return push_sash(obs, -1.0, bar_from_handle=-0.024, handle_end_from_goal=0.0)
