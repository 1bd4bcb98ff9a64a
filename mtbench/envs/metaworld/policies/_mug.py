"""Grasp-and-carry helper shared by the scripted coffee_pull and coffee_push policies.

The hand grasps the mug's cylinder at its centre (the observed mug point): the open fingers (pads 10 cm apart)
straddle it along y, the palm (3.7 cm above the TCP) clears the mug's top by 5 mm and the fingers pass beside the
handle (which points to -x). Held, the mug is slid over the table (lifted 2 mm) until its centre is above the goal
in x-y: the goal lies on the table, 3.5 cm below the observed point, so the remaining x-y error must stay under
3.6 cm; the hand stays at the mug, as success requires.
"""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import grasp_phase, move_lead

MUG_GRASP = dict(above=0.08, xy_tol=0.01, grasp_tol=0.006, hold_tol=0.03,
                 held_below=0.75,  # openness (pad distance / 0.1): open 0.93, closed on the 5.6 cm mug ~0.55
                 empty_below=0.3)  # closed on nothing: ~0
CARRY_LIFT = 0.002
CARRY_SPEED = 0.5


def carry_mug(obs: torch.Tensor, target_xy: torch.Tensor | None = None) -> torch.Tensor:
    """Grasp the mug and slide it until its centre is over ``target_xy`` ([N, 2]; default: the goal)."""
    o = parse(obs)
    hand, prev, mug, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, mug, o["gripper_open"], **MUG_GRASP)
    xy = goal[:, :2] if target_xy is None else target_xy
    rest_z = mug[:, 2] - (mug[:, 2] - 0.035) + CARRY_LIFT  # the mug's centre at rest is 3.5 cm above the table
    carry = torch.stack([hand[:, 0] + xy[:, 0] - mug[:, 0], hand[:, 1] + xy[:, 1] - mug[:, 1],
                         hand[:, 2] + rest_z - mug[:, 2]], dim=-1)
    target = torch.where(held[:, None], carry, target)
    delta = move_lead(hand, prev, target, speed=torch.where(held, CARRY_SPEED, 1.0))
    return action(delta, torch.where(close, 1.0, -1.0))
