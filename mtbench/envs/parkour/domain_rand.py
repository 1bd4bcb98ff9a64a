"""Per-world domain randomization of the Go1, sampled once when the env is built and kept (MTBench
``final_go1_*.yaml`` ``domain_rand``, the Extreme Parkour values).

* friction ``mu``: 64 values ~ U(0.6, 2.0), each world takes one at random (the original's friction buckets);
* added trunk mass ~ U(0, 3) kg; trunk centre-of-mass offset ~ U(-0.2, 0.2) m on each axis (the config's
  ``added_com_range``, large compared with the 0.38 m trunk: kept as the original has it);
* motor strengths ``ms0, ms1`` ~ U(0.8, 1.2) per joint (scales of the PD's Kp and Kd terms).

They are written into batched MuJoCo Warp model fields (:data:`BATCHED_FIELDS`) and the derived constants are
recomputed (``WarpSim.set_const``):

* friction: IsaacGym (PhysX) combines two materials by averaging their coefficients; MuJoCo takes the geom with the
  higher priority. The robot geoms have priority, so each world's robot geoms get ``(mu + mu_terrain) / 2`` with
  ``mu_terrain = 1.0`` (the original terrain material): the same effective coefficient as the original. The
  privileged observation carries ``mu`` itself, as the original's does.
* mass: ``body_mass[trunk] += added``, the trunk inertia scaled by the same mass ratio (PhysX recomputes inertia
  for the new mass), ``body_ipos[trunk] += offset``.
* motor strengths: ``actuator_gainprm[:, 0] = ms0 * KP``, ``actuator_biasprm[:, 1] = -ms0 * KP``,
  ``actuator_biasprm[:, 2] = -ms1 * KD``.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import torch

from . import robot
from .scene import TERRAIN_FRICTION

FRICTION_RANGE = (0.6, 2.0)
FRICTION_BUCKETS = 64
ADDED_MASS_RANGE = (0.0, 3.0)
COM_OFFSET_RANGE = (-0.2, 0.2)
MOTOR_STRENGTH_RANGE = (0.8, 1.2)

BATCHED_FIELDS = (
    "geom_friction", "body_mass", "body_ipos", "body_inertia", "body_subtreemass", "body_invweight0",
    "dof_invweight0", "actuator_gainprm", "actuator_biasprm",
)


@dataclass
class DomainParams:
    """Per-world randomized parameters: ``friction`` [N], ``added_mass`` [N], ``com_offset`` [N, 3],
    ``motor_strength`` [2, N, 12] (ms0, ms1)."""

    friction: torch.Tensor
    added_mass: torch.Tensor
    com_offset: torch.Tensor
    motor_strength: torch.Tensor

    def tensors(self) -> dict[str, torch.Tensor]:
        return {"friction": self.friction, "added_mass": self.added_mass, "com_offset": self.com_offset,
                "motor_strength": self.motor_strength}


def _uniform(shape: tuple[int, ...], bounds: tuple[float, float], generator: torch.Generator,
             device: torch.device) -> torch.Tensor:
    lo, hi = bounds
    return lo + (hi - lo) * torch.rand(shape, generator=generator, device=device)


def sample(n: int, generator: torch.Generator, device: torch.device | str, enabled: bool = True) -> DomainParams:
    """Draw the parameters of ``n`` worlds (``enabled=False``: the nominal robot, friction 1, strengths 1)."""
    device = torch.device(device)
    if not enabled:
        return DomainParams(torch.ones(n, device=device), torch.zeros(n, device=device),
                            torch.zeros(n, 3, device=device), torch.ones(2, n, robot.NUM_JOINTS, device=device))
    buckets = _uniform((FRICTION_BUCKETS,), FRICTION_RANGE, generator, device)
    friction = buckets[torch.randint(0, FRICTION_BUCKETS, (n,), generator=generator, device=device)]
    return DomainParams(
        friction=friction,
        added_mass=_uniform((n,), ADDED_MASS_RANGE, generator, device),
        com_offset=_uniform((n, 3), COM_OFFSET_RANGE, generator, device),
        motor_strength=_uniform((2, n, robot.NUM_JOINTS), MOTOR_STRENGTH_RANGE, generator, device),
    )


def apply(sim, mjm: mujoco.MjModel, params: DomainParams) -> None:
    """Write ``params`` into the batched model fields of ``sim`` (a ``WarpSim`` with :data:`BATCHED_FIELDS`) and
    recompute the derived constants."""
    dev = sim.device
    trunk = mujoco.mj_name2id(mjm, mujoco.mjtObj.mjOBJ_BODY, robot.BASE_BODY)
    robot_geoms = torch.tensor([g for g in range(mjm.ngeom) if mjm.geom_bodyid[g] != 0], device=dev)
    friction = sim.model_field("geom_friction")
    effective = 0.5 * (params.friction + TERRAIN_FRICTION)
    friction[:, robot_geoms, 0] = effective[:, None]
    mass0 = float(mjm.body_mass[trunk])
    sim.model_field("body_mass")[:, trunk] = mass0 + params.added_mass
    sim.model_field("body_inertia")[:, trunk] = (
        torch.as_tensor(mjm.body_inertia[trunk], dtype=torch.float32, device=dev)[None, :]
        * ((mass0 + params.added_mass) / mass0)[:, None])
    sim.model_field("body_ipos")[:, trunk] = (
        torch.as_tensor(mjm.body_ipos[trunk], dtype=torch.float32, device=dev)[None, :] + params.com_offset)
    ms0, ms1 = params.motor_strength[0], params.motor_strength[1]
    gain, bias = sim.model_field("actuator_gainprm"), sim.model_field("actuator_biasprm")
    gain[:, :, 0] = ms0 * robot.KP
    bias[:, :, 1] = -ms0 * robot.KP
    bias[:, :, 2] = -ms1 * robot.KD
    sim.set_const()
