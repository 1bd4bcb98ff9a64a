"""Scripted button_press: push the button with the far finger of the open gripper (see ``_button``).

The TCP stays 1 cm above the button's centre line: the far finger's tapered middle and base (6.9 to 7.2 cm ahead of
the TCP) press the upper half of the cap (radius 4.3 cm) and the palm (3.7 cm above the TCP) passes over it. The
target puts the nominal pushing face at the end of the travel (the success window is its last centimetre); the
palm's front end stays in front of the box.
"""

from __future__ import annotations

import torch

from ._button import press_forward

TCP_ABOVE = 0.01
CONTACT_AHEAD = 0.066
PRESS_SHORT = -0.002


def policy(obs: torch.Tensor) -> torch.Tensor:
    return press_forward(obs, TCP_ABOVE, CONTACT_AHEAD, PRESS_SHORT)
