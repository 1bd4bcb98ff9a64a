"""Pressing helpers shared by the scripted policies of button_press, button_press_wall and
button_press_topdown_wall.

Panda hand geometry that decides how a button facing the robot can be pressed (relative to the TCP, hand pointing
down): the palm box spans ``y ± 0.102``, ``z + 0.037 .. + 0.111``; with the gripper open the far (+y) finger's outer
faces reach ``y + 0.060`` at the tip (``z - 0.0095 .. + 0.0085``), ``+ 0.069`` along its tapered middle (``z - 0.007
.. + 0.027``) and ``+ 0.072`` at its base (``z + 0.025 .. + 0.045``); closed, the fingers reach ``y ± 0.009 / 0.018
/ 0.021``. Pushed by closed fingers the button would let the palm's front end hit the box after about 3 cm of its 6
cm travel; the open gripper's far finger is only 3 to 4 cm behind the palm's front end, which leaves room for the
whole press.
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead

APPROACH_BACK = 0.12  # stage this far in front (-y) of the button face before pushing
ALIGN_TOL = 0.01  # x and z alignment before pushing
PUSH_SPEED = 0.5


def press_forward(obs: torch.Tensor, tcp_above: float, contact_ahead: float, press_depth: float,
                  approach_z: float | None = None) -> torch.Tensor:
    """Actions that press a button facing the robot (observed point = its front face, goal = that face at the end
    of the travel, MTBench's convention) by pushing it along +y with the open gripper's far finger.

    ``tcp_above``: TCP height above the observed point while pushing; ``contact_ahead``: nominal distance of the
    pushing face ahead (+y) of the TCP; ``press_depth``: where the pushing target puts that face relative to the
    goal (negative: short of the end of the travel; the stiff joint limit stops the button there anyway).
    ``approach_z``: height at which the hand flies to the staging point (default: the pushing height).
    """
    o = parse(obs)
    hand, prev, button, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    push_z = button[:, 2] + tcp_above
    fly_z = push_z if approach_z is None else torch.full_like(push_z, approach_z)
    stage_y = button[:, 1] - APPROACH_BACK
    behind = hand[:, 1] < button[:, 1] - contact_ahead + 0.005  # the pushing face is in front of the button face
    aligned = ((hand[:, 0] - button[:, 0]).abs() < ALIGN_TOL) & ((hand[:, 2] - push_z).abs() < ALIGN_TOL)
    stage_low = torch.stack([button[:, 0], stage_y, push_z], dim=-1)
    stage_high = torch.stack([button[:, 0], stage_y, fly_z], dim=-1)
    near_stage = (hand[:, :2] - stage_low[:, :2]).norm(dim=-1) < ALIGN_TOL
    push = torch.stack([button[:, 0], goal[:, 1] + press_depth - contact_ahead, push_z], dim=-1)
    target = torch.where(near_stage[:, None], stage_low, stage_high)
    target = torch.where((behind & aligned)[:, None], push, target)
    pushing = behind & aligned
    delta = move_lead(hand, prev, target, speed=torch.where(pushing, PUSH_SPEED, 1.0))
    return action(delta, -1.0)


HOVER = 0.06  # top-down: TCP height above the button top while aligning in x-y
ALIGNED_XY = 0.012  # top-down: x-y distance under which the hand pushes down
DOWN_SPEED = 0.5  # top-down: slower descent while pressing (less overshoot of the weld-driven hand)


def press_down(obs: torch.Tensor, tcp_above_goal: float) -> torch.Tensor:
    """Actions that press a button pointing up (observed point = its top, goal = the top at the end of the travel)
    with the closed fingers: hover above it, then go straight down until the TCP is ``tcp_above_goal`` above the
    goal (the closed fingertips reach 0.94 cm below the TCP)."""
    o = parse(obs)
    hand, button, goal = o["tcp"], o["obj_pos"], o["goal"]
    aligned = (hand[:, :2] - button[:, :2]).norm(dim=-1) <= ALIGNED_XY
    z = torch.where(aligned, goal[:, 2] + tcp_above_goal, button[:, 2] + HOVER)
    target = torch.cat([button[:, :2], z[:, None]], dim=-1)
    delta = ((target - hand) / 0.01).clamp(-1.0, 1.0)
    dz = torch.where(aligned, delta[:, 2].clamp(-DOWN_SPEED, DOWN_SPEED), delta[:, 2])
    return action(torch.cat([delta[:, :2], dz[:, None]], dim=-1), 1.0)
