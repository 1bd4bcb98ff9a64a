"""Scripted button_press: push the button with the far finger of the open gripper (see ``_button``).

The TCP stays 1 cm above the button's centre line: the fingertips then press the middle of the cap, the fingers'
bases (2.6 cm above the TCP, 6.6 cm ahead of it) touch the cap's top edge, and the palm (3.7 cm above the TCP)
passes over the cap. The hand pushes the face to 2 mm short of the end of the travel (the success window is the
last centimetre); the palm's front end stays in front of the box.
"""

from __future__ import annotations

import torch

from ._button import press_forward

TCP_ABOVE = 0.01
CONTACT_AHEAD = 0.066
PRESS_SHORT = -0.002


def policy(obs: torch.Tensor) -> torch.Tensor:
    return press_forward(obs, TCP_ABOVE, CONTACT_AHEAD, PRESS_SHORT)
