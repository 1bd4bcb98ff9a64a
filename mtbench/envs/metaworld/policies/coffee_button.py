"""Scripted coffee_button: press the machine's button with the closed fingertips, the palm above the machine.

The palm (3.7 cm above the TCP, reaching 10.2 cm ahead of it) has to stay above the machine's top (0.37, 7 cm above
the button's centre) and the closed fingers' bases (2.6 cm above the TCP, 2.6 cm ahead of it) in front of the frame
around the button (1.7 cm behind the button's face), so the TCP stays 3.5 cm above the button's centre: the
fingertips (0.9 cm below the TCP, front face 1.45 cm ahead of it) then press the button's upper edge. Phases,
chosen from distances: rise to the pushing height, move to a staging point 6 cm in front of the button, push to
2.3 cm of the button's 3 cm travel (success needs 2 cm; past 2.7 cm the fingers' bases would meet the frame).
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead

TCP_ABOVE = 0.035
STAGE_BACK = 0.06
TIP_AHEAD = 0.0145  # closed fingertips' front face ahead of the TCP
PRESS = 0.023  # of the 3 cm travel
ALIGN_TOL = 0.008
PUSH_SPEED = 0.4


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, button, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    z = button[:, 2] + TCP_ABOVE
    low = hand[:, 2] < z - 0.015
    rise = torch.stack([hand[:, 0], hand[:, 1], z], dim=-1)
    stage = torch.stack([button[:, 0], button[:, 1] - STAGE_BACK, z], dim=-1)
    aligned = ((hand[:, 0] - button[:, 0]).abs() < ALIGN_TOL) & ((hand[:, 2] - z).abs() < ALIGN_TOL)
    in_front = hand[:, 1] < button[:, 1] - TIP_AHEAD + 0.005
    push_y = goal[:, 1] - (0.03 - PRESS) - TIP_AHEAD
    push = torch.stack([button[:, 0], push_y, z], dim=-1)
    pushing = aligned & in_front & (hand[:, 1] > stage[:, 1] - 0.01)
    target = torch.where(low[:, None], rise, stage)
    target = torch.where(pushing[:, None], push, target)
    delta = move_lead(hand, prev, target, speed=torch.where(pushing, PUSH_SPEED, 1.0))
    return action(delta, 1.0)
