"""Scripted soccer: dribble the ball to the target in front of the goal mouth with the closed fingers.

(Grasping the ball from above is not always possible: when the ball lies within ~17 cm of the goal frame, the
Panda's palm, 10 cm ahead of the fingers along +y, and its wrist hit the goal's top bar on the way down.)

The ball is aimed at a point ``AIM_SHORT`` in front of the target (MTBench's target lies only 3.6 cm in front of
the goal mouth; with the fingers behind a ball there, the Panda's wrist, 7 cm ahead of the fingers, would hit the
goal frame). The push direction ``u`` points from the ball to that point. The hand goes to a staging point behind
the ball (``ball − u·STAGE``), lifting over the ball if it is on the wrong side, comes down to the ball's centre
height there, and then pushes along ``u`` at a limited speed while steering sideways to keep the ball on the
line; it stops once the ball is well inside the success region (scaled distance ``DONE``).
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import move_lead
from ._tools import with_z

BALL_RADIUS = 0.026
CONTACT = BALL_RADIUS + 0.012  # ball centre to the TCP when the closed fingers touch it
STAGE = CONTACT + 0.03  # staging distance behind the ball
HIGH_Z = 0.09  # TCP height when passing over the ball
PUSH_SPEED = 0.4
DONE = 0.045  # ‖(ball − target)·(3, 1, 1)‖ below which the hand stops (success: < 0.07)
AIM_SHORT = 0.03
LINE_TOL = 0.012  # lateral offset from the push line under which the hand pushes
STEER = 1.0  # while pushing, the hand is steered to the other side of the line by this times its offset


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, ball, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    aim = torch.stack([goal[:, 0], goal[:, 1] - AIM_SHORT], dim=-1)
    d = aim - ball[:, :2]
    dist = d.norm(dim=-1)
    u = d / dist.clamp_min(1e-6)[:, None]
    n = torch.stack([-u[:, 1], u[:, 0]], dim=-1)
    rel = hand[:, :2] - ball[:, :2]
    along = (rel * u).sum(-1)  # negative behind the ball
    across = (rel * n).sum(-1)
    ball_z = ball[:, 2]
    low = hand[:, 2] < ball_z + 0.03
    behind = along < -(CONTACT - 0.01)
    on_line = across.abs() < LINE_TOL
    engaged = behind & on_line & low & (along > -(STAGE + 0.01))

    stage = ball[:, :2] - STAGE * u
    # staging: come down behind the ball; pass over it first if the hand is not behind it
    near_stage = (hand[:, :2] - stage).norm(dim=-1) < 0.01
    stage_z = torch.where(near_stage | (behind & low), ball_z, torch.full_like(ball_z, HIGH_Z))
    stage_target = with_z(stage, stage_z)
    pass_over = ~behind & low & ~near_stage
    stage_target = torch.where(pass_over[:, None], with_z(hand[:, :2], HIGH_Z), stage_target)
    # pushing: along u through the ball, steering the contact back onto the line
    push_xy = ball[:, :2] - CONTACT * u + u * dist.clamp(max=0.02)[:, None] - n * (across * STEER)[:, None]
    push_target = with_z(push_xy, ball_z)
    err = ball - goal
    done = torch.stack([3.0 * err[:, 0], err[:, 1], err[:, 2]], dim=-1).norm(dim=-1) < DONE
    target = torch.where(engaged[:, None], push_target, stage_target)
    target = torch.where(done[:, None], hand, target)
    delta = move_lead(hand, prev, target, speed=torch.where(engaged, PUSH_SPEED, 1.0))
    return action(delta, 1.0)
