"""Scripted reach: move straight to the goal with the gripper open."""

from __future__ import annotations

import torch

from ._common import action, move, parse


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    return action(move(o["tcp"], o["goal"]), -1.0)
