"""Scripted faucet_open: push the handle counter-clockwise (seen from above) to the end of its travel (see
``_faucet``)."""

from __future__ import annotations

import torch

from ._common import parse
from ._faucet import turn


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    return turn(o["tcp"], o["obj_pos"], o["goal"], sign=1.0, site_side=-0.015)
