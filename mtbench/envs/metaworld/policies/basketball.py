"""Scripted basketball: grasp the ball at its equator, carry it to a point straight above the hoop and let it
drop through the ring (the ring leaves 4 mm around the ball; a ball caught on the rim still ends within the
success radius of the hoop centre)."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import grasp_phase, move_lead, shifted

BALL_GRASP = dict(above=0.07, xy_tol=0.01, grasp_tol=0.003, hold_tol=0.025,
                  held_below=0.8,  # openness: open 0.91, closed on the 6 cm ball ~0.6
                  empty_below=0.3)
DROP_ABOVE = 0.085  # ball centre above the hoop centre when released (its bottom clears the ring by 2 cm; the hand
# clears the backboard top)
OVER_HOOP = 0.004  # x-y alignment of the ball with the hoop before release
CARRY_SPEED = 0.8  # horizontal carry (faster lets the ball slip in the flat pads)
RISE_SPEED = 1.0
RISE_BEFORE_HOOP = 0.17  # rise at least this far in front of the hoop centre (palm 10.2 cm + ring 5.5 cm)
APPROACH_SPEED = 0.4  # |action| for the last stretch over the hoop (precise alignment)


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, ball, hoop = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, ball, o["gripper_open"], **BALL_GRASP)
    # from the start pose (TCP 20 cm up) come down to the approach height while staying RISE_BEFORE_HOOP in front
    # of the hoop: on the way over to a ball near the hoop, the palm (10 cm ahead of the TCP) would otherwise sweep
    # through the ring (25 cm up)
    approach_z = ball[:, 2] + BALL_GRASP["above"]
    descend_first = (hand[:, 2] > approach_z + 0.02) & ((hand[:, :2] - ball[:, :2]).norm(dim=-1) > 0.02)
    descend = torch.stack([ball[:, 0], torch.minimum(ball[:, 1], hoop[:, 1] - RISE_BEFORE_HOOP), approach_z], dim=-1)
    target = torch.where(descend_first[:, None], descend, target)
    drop_point = shifted(hoop, dz=DROP_ABOVE)
    to_drop = ball - drop_point
    aligned = (to_drop[:, :2].norm(dim=-1) < OVER_HOOP) & (to_drop[:, 2].abs() < 0.01)
    near = to_drop.norm(dim=-1) < 0.05
    # above the hoop (being released or falling through): keep the hand still, the gripper open
    over_hoop = ((ball[:, :2] - hoop[:, :2]).norm(dim=-1) < 0.02) & (ball[:, 2] > hoop[:, 2] - 0.1)
    release = (held & aligned) | (~held & over_hoop)
    # rise to the drop height first, with the hand far enough in front of the hoop that its 20 cm long palm stays
    # clear of the ring; below the drop height the palm or the wrist would hit the ring on the way
    low = (to_drop[:, 2] < -0.02) & (to_drop[:, :2].norm(dim=-1) > 0.02)
    rise_ball = torch.stack([ball[:, 0], torch.minimum(ball[:, 1], hoop[:, 1] - RISE_BEFORE_HOOP), drop_point[:, 2]],
                            dim=-1)
    carry = torch.where(low[:, None], hand + rise_ball - ball, hand - to_drop)
    target = torch.where(held[:, None], carry, target)
    target = torch.where(release[:, None], hand, target)
    speed = torch.where(held & near, APPROACH_SPEED, torch.where(held & low, RISE_SPEED, CARRY_SPEED))
    delta = move_lead(hand, prev, target, speed=speed)
    return action(delta, torch.where(close & ~release, 1.0, -1.0))
