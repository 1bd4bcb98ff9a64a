"""Scripted button_press_topdown: close the fingers, hover above the button, then press it straight down (as
button_press_topdown_wall, without a wall in the way).

The TCP goes down to 1.15 cm above the goal (the end of the travel): the closed fingertips (0.94 cm below the TCP)
then press the button about 5.8 cm, inside the success window (5 to 7 cm).
"""

from __future__ import annotations

import torch

from ._button import press_down

TCP_ABOVE_GOAL = 0.0115


def policy(obs: torch.Tensor) -> torch.Tensor:
    return press_down(obs, TCP_ABOVE_GOAL)
