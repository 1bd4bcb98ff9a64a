"""Scripted handle_press: closed fingers over the top of the grip, then straight down to the end of the travel."""

from __future__ import annotations

import torch

from ._common import parse
from ._handle import press_down


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    return press_down(o["tcp"], o["obj_pos"], o["goal"])
