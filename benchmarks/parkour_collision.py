"""Physics cost of the Parkour terrain representations and robot collision sets (MuJoCo Warp, physics only).

For every ``--representation`` (``tiles``: one heightfield per tile selected per world through ``geom_dataid``, the
env's default; ``grid``: one heightfield for the whole terrain grid) and every ``--collision`` set (``feet``,
``legs`` = feet + calves + thighs, ``all`` = + hips and trunk), builds the Go1 + terrain model of ``mtbench.envs.parkour.scene`` for
``--num-envs`` worlds with the env's domain randomization and buffer sizes, spreads the robots over the tiles and
runs a PD controller (not random torques, which make the robot fall and every geom touch):

* ``--controller trot`` (default): trotting in place (diagonal legs lift their feet in turn at 2 Hz);
* ``--controller stand``: holding the default pose.

``--spawn spread`` (default) drops each robot at a random point along its tile (on obstacles, stairs, ramps, into
pits: the contact load of robots crossing the terrain); ``--spawn origin`` drops it at the tile's spawn point (flat
ground). After ``--warmup`` policy steps (the robots land and settle), ``--steps`` policy steps of 4 physics steps are
timed (physics graph replays, ``torch.cuda.synchronize`` around the loop). Printed per configuration: physics steps/s
(worlds x physics steps / s), the equivalent env steps/s (/ 4), contacts per world (mean and the fullest world),
worlds touching the terrain with a thigh/calf, worlds whose state is non-finite (NaN) or ran away (|qvel| > 1e4,
what the env resets as unhealthy), worlds whose buffers overflowed (by MuJoCo Warp overflow kind, over the whole
run: NEFC = constraint rows, HFIELD = more than 50 prisms under one geom, CCD, ...; ITERATIONS/LS_ITERATIONS are
solver limits, not failures), fallen worlds (base below -0.25 m or upside down), and the build time (model, data,
graph capture; the first build of a collision set also compiles its kernels).

    python benchmarks/parkour_collision.py --num-envs 16384
    python benchmarks/parkour_collision.py --num-envs 4096 16384 --representation grid --collision legs all
"""

from __future__ import annotations

import argparse
import platform
import time

import mujoco_warp as mjw
import numpy as np
import torch
import warp as wp

from mtbench.envs.parkour import domain_rand, robot
from mtbench.envs.parkour.scene import TERRAIN_REPRESENTATIONS, build_scene
from mtbench.envs.parkour.terrain import TerrainConfig, generate_terrain
from mtbench.sim import WarpSim
from mtbench.sim.warp_sim import FATAL_OVERFLOW
from _timing import sync

TROT_HZ = 2.0
# rad added to the default thigh / calf angles at the top of a foot's lift (a nominal Go1 drifts < 0.3 m in 10 s)
TROT_THIGH, TROT_CALF = 0.2, -0.5


def controller_targets(kind: str, cycle_steps: int) -> torch.Tensor:
    """Joint targets ``[cycle_steps, 12]`` for one controller cycle at the policy rate (50 Hz)."""
    q = np.tile(robot.DEFAULT_JOINT_POS, (cycle_steps, 1))
    if kind == "trot":
        t = np.arange(cycle_steps) * robot.SIM_DT * robot.DECIMATION
        for leg, phase in zip(range(4), (0.0, np.pi, np.pi, 0.0)):  # FR+RL, then FL+RR
            lift = np.maximum(np.sin(2 * np.pi * TROT_HZ * t + phase), 0.0)
            q[:, 3 * leg + 1] += TROT_THIGH * lift
            q[:, 3 * leg + 2] += TROT_CALF * lift
    return torch.tensor(q, dtype=torch.float32)


def spawn_states(terrain, scene, n: int, spawn: str, generator: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    """Initial ``qpos`` ``[n, 19]`` (physics frame) and tile index ``[n, 2]`` of every world: world ``w`` on tile
    ``(w % rows, (w // rows) % cols)``, upright, 0.42 m above the highest ground under its trunk."""
    rows, cols = terrain.tile_origins.shape[:2]
    w = np.arange(n)
    tile = np.stack([w % rows, (w // rows) % cols], axis=1)
    origin = terrain.tile_origins[tile[:, 0], tile[:, 1]].astype(np.float64)
    if spawn == "spread":
        u = torch.rand(n, generator=generator).numpy()
        origin[:, 0] += u * (terrain.config.tile_length - 2.0)  # x from 1 m to L - 1 m along the tile
        dx, dy = np.meshgrid(np.linspace(-0.3, 0.3, 7), np.linspace(-0.15, 0.15, 4), indexing="ij")
        ground = terrain.height_at(origin[:, :1] + dx.ravel(), origin[:, 1:2] + dy.ravel()).max(axis=1)
        origin[:, 2] = ground
    offset = scene.tile_offset[tile[:, 0], tile[:, 1]]
    qpos = np.stack([robot.standing_qpos(tuple(p)) for p in origin - offset + [0.0, 0.0, robot.BASE_INIT_HEIGHT]])
    return torch.tensor(qpos, dtype=torch.float32), torch.tensor(tile)


def _contacts_per_world(sim: WarpSim) -> tuple[float, int]:
    nacon = int(wp.to_torch(sim.data.nacon)[0])
    world = wp.to_torch(sim.data.contact.worldid)[: min(nacon, sim.data.contact.worldid.shape[0])]
    per_world = torch.bincount(world.long(), minlength=sim.nworld)
    return nacon / sim.nworld, int(per_world.max()) if nacon else 0


def overflow_kinds(flags: torch.Tensor) -> str:
    """``KIND:worlds`` for every MuJoCo Warp overflow kind set in the per-world ``flags``."""
    parts = []
    for name, bit in mjw.OverflowType.__members__.items():
        if name in ("NONE", "ALL"):
            continue
        count = int(((flags & int(bit)) != 0).sum())
        if count:
            parts.append(f"{name}:{count}")
    return " ".join(parts) or "-"


def measure(terrain, representation: str, collision: str, n: int, device: str, steps: int, warmup: int,
            controller: str, spawn: str, seed: int = 0) -> dict:
    t0 = time.perf_counter()
    scene = build_scene(terrain, collision, representation)
    pairs = scene.contact_pairs
    nconmax, njmax = 4 * pairs, 3 * 4 * pairs + robot.NUM_JOINTS  # the env's defaults
    batched = domain_rand.BATCHED_FIELDS + (("geom_dataid",) if representation == "tiles" else ())
    sim = WarpSim(scene.mjm, n, device, substeps=robot.DECIMATION, nconmax=nconmax, njmax=njmax,
                  batched_fields=batched, contact_forces=True)
    gen = torch.Generator().manual_seed(seed)
    domain_rand.apply(sim, scene.mjm, domain_rand.sample(n, torch.Generator(device=sim.device).manual_seed(seed),
                                                         sim.device))
    qpos, tile = spawn_states(terrain, scene, n, spawn, gen)
    if representation == "tiles":
        hfield = torch.as_tensor(scene.tile_hfield)[tile[:, 0], tile[:, 1]]
        sim.model_field("geom_dataid")[:, scene.hfield_geom] = hfield.to(sim.device, torch.int32)
    sim.reset(torch.ones(n, dtype=torch.bool, device=sim.device))
    sim.qpos.copy_(qpos.to(sim.device))
    sim.kinematics()
    cycle = int(round(1.0 / (TROT_HZ * robot.SIM_DT * robot.DECIMATION)))
    targets = controller_targets(controller, cycle).to(sim.device)
    dev = sim.device
    sync(dev)
    build_s = time.perf_counter() - t0

    bad = torch.zeros(n, dtype=torch.bool, device=dev)
    for i in range(warmup):
        sim.ctrl.copy_(targets[i % cycle].expand(n, -1))
        sim.step()
        bad |= sim.unhealthy()
    sync(dev)
    t0 = time.perf_counter()
    for i in range(steps):
        sim.ctrl.copy_(targets[(warmup + i) % cycle].expand(n, -1))
        sim.step()
    sync(dev)
    elapsed = time.perf_counter() - t0
    # contact statistics and health over a few more steps (host reads, not timed)
    contacts, fullest, legs = [], 0, torch.zeros(n, dtype=torch.bool, device=dev)
    mjm = scene.mjm
    leg_bodies = [mjm.body(b).id for b in robot.THIGH_BODIES + robot.CALF_BODIES]
    for i in range(10):
        sim.ctrl.copy_(targets[(warmup + steps + i) % cycle].expand(n, -1))
        sim.step()
        bad |= sim.unhealthy()
        mean, top = _contacts_per_world(sim)
        contacts.append(mean)
        fullest = max(fullest, top)
        legs |= (torch.linalg.vector_norm(sim.body_contact_force[:, leg_bodies], dim=-1) > 0.1).any(-1)
    nan = ~torch.isfinite(sim.qpos).all(-1) | ~torch.isfinite(sim.qvel).all(-1)
    runaway = nan | (torch.nan_to_num(sim.qvel, nan=0.0).abs().amax(-1) > 1e4)
    flags = wp.to_torch(sim.data.overflow).clone()
    overflow = (flags & FATAL_OVERFLOW) != 0
    quat = sim.qpos[:, 3:7]
    upside_down = (1.0 - 2.0 * (quat[:, 1] ** 2 + quat[:, 2] ** 2)) < 0.0  # body z axis pointing down
    fallen = (sim.qpos[:, 2] < -0.25) | upside_down
    return {
        "representation": representation,
        "collision": collision,
        "pairs": pairs,
        "num_envs": n,
        "physics_steps_per_s": n * steps * robot.DECIMATION / elapsed,
        "env_steps_per_s": n * steps / elapsed,
        "contacts_per_world": float(np.mean(contacts)),
        "max_contacts": fullest,
        "legs_touching": float(legs.float().mean()),
        "nan": int(nan.sum()),
        "runaway": int(runaway.sum()),
        "overflow": int(overflow.sum()),
        "unhealthy": int((bad | runaway | overflow).sum()),
        "overflow_kinds": overflow_kinds(flags),
        "fallen": float(fallen.float().mean()),
        "build_s": build_s,
        "nconmax_njmax": f"{nconmax}/{njmax}",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--num-envs", type=int, nargs="+", default=[16384])
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--representation", nargs="+", choices=TERRAIN_REPRESENTATIONS,
                        default=list(TERRAIN_REPRESENTATIONS))
    parser.add_argument("--collision", nargs="+", choices=robot.TERRAIN_COLLISIONS,
                        default=list(robot.TERRAIN_COLLISIONS))
    parser.add_argument("--controller", choices=("trot", "stand"), default="trot")
    parser.add_argument("--spawn", choices=("spread", "origin"), default="spread")
    parser.add_argument("--steps", type=int, default=200, help="timed policy steps (x4 physics steps)")
    parser.add_argument("--warmup", type=int, default=50, help="policy steps before timing (landing)")
    parser.add_argument("--num-rows", type=int, default=10, help="difficulty rows of the terrain grid")
    parser.add_argument("--easy", action="store_true", help="difficulty 0 on every row (Parkour-easy terrain)")
    args = parser.parse_args()
    terrain = generate_terrain(TerrainConfig(num_rows=args.num_rows, easy=args.easy))
    name = torch.cuda.get_device_name() if args.device.startswith("cuda") else platform.processor() or "cpu"
    print(f"device: {name}; torch {torch.__version__}; warp {wp.__version__}; date {time.strftime('%Y-%m-%d')}; "
          f"terrain {args.num_rows} x {terrain.config.num_cols} ({'easy' if args.easy else 'hard'}), "
          f"controller {args.controller}, spawn {args.spawn}, {args.steps} timed steps")
    print("| representation | collision (pairs) | envs | physics steps/s | env steps/s | contacts/world (max) | "
          "legs touching | NaN / runaway | overflow (kinds) | unhealthy | fallen | nconmax/njmax | build s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.num_envs:
        for rep in args.representation:
            for col in args.collision:
                r = measure(terrain, rep, col, n, args.device, args.steps, args.warmup, args.controller, args.spawn)
                print(f"| {r['representation']} | {r['collision']} ({r['pairs']}) | {r['num_envs']} | "
                      f"{r['physics_steps_per_s']:,.0f} | {r['env_steps_per_s']:,.0f} | "
                      f"{r['contacts_per_world']:.1f} ({r['max_contacts']}) | {r['legs_touching']:.1%} | "
                      f"{r['nan']} / {r['runaway']} | {r['overflow']} ({r['overflow_kinds']}) | {r['unhealthy']} | "
                      f"{r['fallen']:.1%} | {r['nconmax_njmax']} | {r['build_s']:.1f} |",
                      flush=True)


if __name__ == "__main__":
    main()
