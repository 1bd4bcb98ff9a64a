"""Control helpers shared by the scripted grasping policies (push, pick_place, peg_insert_side)."""

from __future__ import annotations

import torch

from ..robot import ACTION_SCALE

# The hand trails the mocap target by about this many control steps of its own motion (weld + arm damping:
# at 1 cm/step the lag settles at 3 cm), so ``hand + LAG_STEPS * (hand - previous hand)`` estimates the target.
LAG_STEPS = 3.0


def shifted(p: torch.Tensor, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> torch.Tensor:
    """``p + (dx, dy, dz)`` for ``[N, 3]`` points (no host-to-device copy)."""
    return torch.stack([p[:, 0] + dx, p[:, 1] + dy, p[:, 2] + dz], dim=-1)


def move_lead(hand: torch.Tensor, prev_hand: torch.Tensor, target: torch.Tensor,
              speed: torch.Tensor | float = 1.0) -> torch.Tensor:
    """Displacement action that puts the (estimated) mocap target on ``target``: the hand then settles there
    without the overshoot that a proportional step on the hand position gives. ``speed`` (float or ``[N]``) caps
    |action| per axis."""
    mocap = hand + LAG_STEPS * (hand - prev_hand)
    delta = (target - mocap) / ACTION_SCALE
    if isinstance(speed, torch.Tensor):
        speed = speed[:, None]
        return torch.maximum(torch.minimum(delta, speed), -speed)
    return delta.clamp(-speed, speed)


def grasp_phase(hand: torch.Tensor, grasp: torch.Tensor, opened: torch.Tensor, *, above: float, xy_tol: float,
                grasp_tol: float, hold_tol: float, held_below: float, empty_below: float
                ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The approach-and-grasp part shared by the policies, from distances only (stateless).

    Returns ``(target, close, held)``: the hand target while not holding (above ``grasp`` until aligned in xy
    within ``xy_tol``, then down onto it; the current hand position while the fingers close), whether to close the
    gripper (hand within ``grasp_tol`` of ``grasp``, or holding), and whether the object is held (hand within
    ``hold_tol`` and the openness between ``empty_below`` and ``held_below``).
    """
    dist = (hand - grasp).norm(dim=-1)
    aligned = (hand[:, :2] - grasp[:, :2]).norm(dim=-1) < xy_tol
    held = (dist < hold_tol) & (opened < held_below) & (opened > empty_below)
    close = (dist < grasp_tol) | held
    target = torch.where(aligned[:, None], grasp, shifted(grasp, dz=above))
    target = torch.where(close[:, None], hand, target)  # wait while the fingers close
    return target, close, held


# Grasp parameters shared by the puck policies (push, pick_place): the 4 cm puck, approached from 6 cm above.
PUCK_GRASP = dict(above=0.06, xy_tol=0.01, grasp_tol=0.005, hold_tol=0.025,
                  held_below=0.6,  # openness: open 0.91, closed on the 4 cm puck ~0.48
                  empty_below=0.3)  # openness below which the gripper closed on nothing
PUCK_CARRY_SPEED = 0.5  # |action| per axis while carrying the puck


# --- added for group c ---
# Grasp parameters for the 4 cm, 10 g objects of pick_out_of_hole and shelf_place: the fingers squeeze such a light
# object's contacts about 5 mm deep each (openness ~0.30 closed on it, 0.48 on the 0.75 kg puck), so "closed on
# nothing" (~0.11) is told apart at a lower openness.
LIGHT_GRASP = dict(PUCK_GRASP, empty_below=0.2)


def holding(hand: torch.Tensor, obj: torch.Tensor, opened: torch.Tensor, params: dict) -> torch.Tensor:
    """``grasp_phase``'s "held" test against the object itself (hand within ``hold_tol`` of ``obj`` and the
    openness between ``empty_below`` and ``held_below``), for policies that grasp at a point other than ``obj``."""
    return ((hand - obj).norm(dim=-1) < params["hold_tol"]) & (opened < params["held_below"]) & (
        opened > params["empty_below"])
