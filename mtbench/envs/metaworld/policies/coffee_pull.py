"""Scripted coffee_pull: grasp the mug at its centre and slide it back onto the goal (see ``_mug``)."""

from __future__ import annotations

import torch

from ._mug import carry_mug


def policy(obs: torch.Tensor) -> torch.Tensor:
    return carry_mug(obs)
