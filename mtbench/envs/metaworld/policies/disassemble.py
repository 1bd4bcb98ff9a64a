"""Scripted disassemble: grasp the nut's handle from above and lift the nut straight up off the peg."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import grasp_phase, move_lead

HANDLE_GRASP = dict(above=0.06, xy_tol=0.008, grasp_tol=0.004, hold_tol=0.02,
                    held_below=0.6,  # openness: open 0.91, closed on the 3.8 cm handle ~0.45
                    empty_below=0.25)
LIFT = 0.17  # lift the handle this far (the ring clears the peg top after ~9 cm; success after 10.6 cm)
LIFT_SPEED = 0.6


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, handle, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, handle, o["gripper_open"], **HANDLE_GRASP)
    # held: straight up above the handle's start (the goal is 15 cm above the ring's start; the handle is beside it)
    lift = torch.stack([hand[:, 0], hand[:, 1], goal[:, 2] + (LIFT - 0.15)], dim=-1)
    target = torch.where(held[:, None], lift, target)
    delta = move_lead(hand, prev, target, speed=torch.where(held, LIFT_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
