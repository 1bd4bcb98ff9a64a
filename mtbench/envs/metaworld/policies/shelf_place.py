"""Scripted shelf-place: grasp the block from above, lift it to the goal's height (moving sideways to the goal's x)
in front of the shelf, then carry it straight in onto the middle board at the goal and hold it there.

The goal lies 5 cm above the board's top face; the block (4 cm) held at the goal clears the board, and the hand
(its underside 3.7 cm above the TCP, 20 cm long along y) fits between the side walls with its front end past the
board's rear edge (the shelf has no back wall to collide with, as in MTBench). For goals right of the centre
(x > 0) the forearm, which hangs 1 to 12 cm to the left (-x) of the TCP, can brush the shelf's left wall on the way
in; the arm's free elbow gives way and the block still arrives."""

from __future__ import annotations

import torch

from ._common import action, parse
from ._grasp import LIGHT_GRASP, grasp_phase, move_lead

HIGH_ENOUGH = 0.015  # the block goes in once it is this close to the goal's height


def policy(obs: torch.Tensor) -> torch.Tensor:
    o = parse(obs)
    hand, prev, obj, goal = o["tcp"], o["prev_tcp"], o["obj_pos"], o["goal"]
    target, close, held = grasp_phase(hand, obj, o["gripper_open"], **LIGHT_GRASP)
    raise_ = torch.stack([goal[:, 0], obj[:, 1], goal[:, 2]], dim=-1)
    obj_target = torch.where((obj[:, 2] < goal[:, 2] - HIGH_ENOUGH)[:, None], raise_, goal)
    target = torch.where(held[:, None], hand + obj_target - obj, target)
    return action(move_lead(hand, prev, target), torch.where(close, 1.0, -1.0))
