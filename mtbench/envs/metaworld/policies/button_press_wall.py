"""Scripted button_press_wall: reach over the wall and push the button with the far finger of the open gripper.

The wall (top at 0.15) stands 9.6 cm in front of the button's face, too close for the open fingers (14 cm across at
their bases) to drop between them, so the TCP stays 4.3 cm above the button's centre line: the fingertips (0.95 cm
below the TCP) clear the wall and the far finger (6 to 7 cm ahead of the TCP) presses the top centimetre of the cap
(radius 4.3 cm) while the palm passes over it, its front end clear of the box up to the end of the travel.
"""

from __future__ import annotations

import torch

from ._button import press_forward

TCP_ABOVE = 0.043
CONTACT_AHEAD = 0.0545
PRESS_SHORT = -0.004
APPROACH_Z = 0.2


def policy(obs: torch.Tensor) -> torch.Tensor:
    return press_forward(obs, TCP_ABOVE, CONTACT_AHEAD, PRESS_SHORT, approach_z=APPROACH_Z)
