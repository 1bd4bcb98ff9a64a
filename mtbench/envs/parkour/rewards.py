"""Parkour reward terms (MTBench ``legged_base.py`` ``_reward_*`` with ``final_go1_*.yaml`` ``rewards.scales``).

Each term is a plain function ``f(env) -> Tensor[N]`` of the env's named state; :func:`compute_reward` weighs them
by ``scale * dt`` (dt = 0.02 s, the policy step) and, with ``only_positive``, clips the total at 0.

State read from ``env`` (all ``[N, ...]`` tensors, world frame unless noted):
``target_pos_rel`` (current goal xy - base xy), ``base_lin_vel_world`` (the trunk's centre-of-mass velocity),
``command`` (forward speed), ``target_yaw``, ``yaw``, ``joint_torque``, ``joint_vel``, ``body_contact_force``
(``[N, nbody, 3]``) and ``penalized_bodies`` (body ids of the thighs and calves); ``base_quat`` (w, x, y, z) for
``orientation``.

``orientation`` is not one of MTBench's Go1 terms (not in :data:`REWARD_SCALES`, so it is off): it is legged_gym's
``_reward_orientation``, for ablations of the trunk's posture (``reward_scales``).
"""

from __future__ import annotations

from typing import Callable, Mapping

import torch

from ..rotations import quat_rotate_inverse

EPS = 1e-5
COLLISION_FORCE = 0.1  # N: a thigh/calf "collides" above this contact force
STILL_SIGMA = 0.2  # tracking_goal_vel's Gaussian width for a zero speed command


def tracking_goal_vel(env) -> torch.Tensor:
    """``min(v_xy . g, cmd) / cmd`` with ``g`` the unit vector to the current goal (``exp(-(v.g - cmd)^2 / 0.2)``
    for a zero command)."""
    rel = env.target_pos_rel
    direction = rel / (torch.linalg.vector_norm(rel, dim=-1, keepdim=True) + EPS)
    speed = (direction * env.base_lin_vel_world[:, :2]).sum(-1)
    cmd = env.command
    move = torch.minimum(speed, cmd) / (cmd + EPS)
    still = torch.exp(-torch.square(speed - cmd) / STILL_SIGMA)
    return torch.where(cmd > 0, move, torch.where(cmd == 0, still, torch.zeros_like(move)))


def tracking_yaw(env) -> torch.Tensor:
    """``exp(-|target_yaw - yaw|)`` (angles not wrapped, as the original)."""
    return torch.exp(-torch.abs(env.target_yaw - env.yaw))


def energy_cost(env) -> torch.Tensor:
    """``sum_j max(tau_j * qdot_j, 0)``: positive mechanical power of the joints."""
    return torch.clamp(env.joint_torque * env.joint_vel, min=0.0).sum(-1)


def collision(env) -> torch.Tensor:
    """Number of thigh and calf bodies with a contact force above 0.1 N."""
    force = env.body_contact_force[:, env.penalized_bodies]
    return (torch.linalg.vector_norm(force, dim=-1) > COLLISION_FORCE).float().sum(-1)


def orientation(env) -> torch.Tensor:
    """``g_x^2 + g_y^2`` of gravity's unit vector in the trunk frame (legged_gym's ``_reward_orientation``): 0 level,
    ``sin^2`` of the tilt for a pure roll or pitch. Not an MTBench Go1 term (off by default)."""
    down = torch.zeros_like(env.base_quat[:, 1:])
    down[:, 2] = -1.0
    g = quat_rotate_inverse(env.base_quat, down)
    return torch.square(g[:, 0]) + torch.square(g[:, 1])


REWARD_FUNCTIONS: dict[str, Callable[[object], torch.Tensor]] = {
    "tracking_goal_vel": tracking_goal_vel,
    "tracking_yaw": tracking_yaw,
    "energy_cost": energy_cost,
    "collision": collision,
    "orientation": orientation,
}
REWARD_SCALES: dict[str, float] = {
    "tracking_goal_vel": 4.0,
    "tracking_yaw": 1.0,
    "energy_cost": -0.0005,
    "collision": -10.0,
}


def check_scales(scales: Mapping[str, float]) -> dict[str, float]:
    """Validated copy of a ``{term: scale}`` config (zero scales are dropped, as the original does)."""
    unknown = [k for k in scales if k not in REWARD_FUNCTIONS]
    if unknown:
        raise ValueError(f"unknown reward terms {unknown}; valid choices: {sorted(REWARD_FUNCTIONS)}")
    return {k: float(v) for k, v in scales.items() if v != 0}


def compute_reward(env, scales: Mapping[str, float], dt: float,
                   only_positive: bool = True) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """Total reward ``[N]`` = ``sum_k f_k(env) * scale_k * dt`` (clipped at >= 0 if ``only_positive``) and the
    weighted terms by name."""
    terms = {name: REWARD_FUNCTIONS[name](env) * (scale * dt) for name, scale in scales.items()}
    total = torch.stack(list(terms.values())).sum(0) if terms else torch.zeros_like(env.command)
    if only_positive:
        total = torch.clamp(total, min=0.0)
    return total, terms
