"""Which robot geoms make MuJoCo Warp's heightfield collision work in Parkour: the convex-collision calls per
robot-geom/heightfield pair, counted from the simulated states of a trained policy.

MuJoCo Warp runs one thread per robot-geom/heightfield pair; the thread walks the heightfield triangles (prisms) under
the geom's bounding box and runs GJK (and EPA where they overlap) on every prism whose top reaches the geom's lowest
point (`ccd_hfield_kernel`). This script repeats that selection in numpy on the states of an evaluation rollout
(sampled actions, as in training) and reports, per geom kind, the calls per pair: mean, 99th percentile and maximum,
and per sampled step the largest count of each kind (the longest thread of that kernel launch). It runs on the CPU.
``--split N`` counts, on the same states, what the threads would test with the env's ``robot_collision_pieces=N``
(each box and long capsule as N pieces along its longest axis: the same solid in N pairs), without changing the
physics of the rollout.

    python benchmarks/parkour_prism_load.py CHECKPOINT --num-envs 84 --steps 600 --every 20 [--split 4]

Results: docs/benchmarks.md, section 7 ("Which geoms make the heightfield work").
"""

from __future__ import annotations

import argparse
import math
import time
from collections import defaultdict

import mujoco
import numpy as np
import torch
import warp as wp
from omegaconf import OmegaConf

from mtbench.envs.make import is_parkour
from mtbench.envs.parkour import robot
from mtbench.evaluation.policy import load_policy, make_eval_env, read_checkpoint
from mtbench.trainer.rollout import base_env


def geom_kind(m: mujoco.MjModel, g: int) -> str:
    """A readable class of robot geom: foot, calf, thigh, hip (capsules or spheres by the Go1's names), trunk, camera."""
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
    for key in ("foot", "calf", "thigh", "hip", "camera"):
        if key in name.lower():
            return key
    body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])) or ""
    return "trunk" if body == "trunk" else f"{name or body or g}"


def half_extents(m: mujoco.MjModel, g: int, rot: np.ndarray) -> np.ndarray:
    """Half extents ``[3]`` of the geom's axis-aligned box in the heightfield frame (identity rotation)."""
    size = m.geom_size[g]
    kind = int(m.geom_type[g])
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return np.full(3, size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return np.abs(rot[:, 2]) * size[1] + size[0]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return np.abs(rot) @ size
    raise ValueError(f"geom {g}: type {kind} is not a Go1 collision shape")


def pieces(m: mujoco.MjModel, g: int, centre: np.ndarray, rot: np.ndarray,
           split: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The geom as the env's ``robot_collision_pieces=split`` cuts it (``robot.is_split``, ``robot.box_pieces``,
    ``robot.segment_pieces``: boxes along their longest side, capsules longer than their radius along their segment,
    the rest whole), as ``[(centre, half_extents), ...]`` of the pieces' bounding boxes in the heightfield frame."""
    size = np.array(m.geom_size[g], dtype=float)
    kind = int(m.geom_type[g])
    if split == 1 or not robot.is_split(kind, size):
        return [(centre, half_extents(m, g, rot))]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:  # pieces in the geom's frame, then rotated into the heightfield's
        return [(centre + rot @ np.array(local), np.abs(rot) @ np.array(half))
                for local, half in robot.box_pieces(np.zeros(3), size, split)]
    segment = (0.0, 0.0, -size[1], 0.0, 0.0, size[1])  # a capsule's segment along its z
    out = []
    for part in robot.segment_pieces(segment, split):
        a, b = np.array(part[:3]), np.array(part[3:])
        out.append((centre + rot @ (0.5 * (a + b)), np.abs(rot[:, 2]) * 0.5 * np.linalg.norm(b - a) + size[0]))
    return out


def prism_calls(heights: np.ndarray, size: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> int:
    """Prisms the kernel tests for a geom with bounds ``lo``/``hi`` (heightfield frame): triangles of the cells under
    the bounds whose top reaches ``lo[2]``. ``heights``: ``[nrow, ncol]`` metres; ``size``: MuJoCo's hfield size."""
    nrow, ncol = heights.shape
    xs, ys = 0.5 * (ncol - 1) / size[0], 0.5 * (nrow - 1) / size[1]
    cmin, cmax = max(0, math.floor((lo[0] + size[0]) * xs)), min(ncol - 1, math.ceil((hi[0] + size[0]) * xs))
    rmin, rmax = max(0, math.floor((lo[1] + size[1]) * ys)), min(nrow - 1, math.ceil((hi[1] + size[1]) * ys))
    if rmax <= rmin or cmax <= cmin:
        return 0
    h = heights[rmin: rmax + 1, cmin: cmax + 1]  # vertices (r, c)
    a, b = h[:-1, :-1], h[1:, :-1]  # (r, c - 1), (r + 1, c - 1)
    c, d = h[:-1, 1:], h[1:, 1:]  # (r, c), (r + 1, c)
    first = np.maximum(np.maximum(a, b), c)  # the kernel's two triangles per cell
    second = np.maximum(np.maximum(b, c), d)
    return int((first >= lo[2]).sum() + (second >= lo[2]).sum())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("checkpoint", help="a Parkour training checkpoint (full or slim)")
    p.add_argument("--num-envs", type=int, default=84, help="worlds, split over the terrains as in training")
    p.add_argument("--steps", type=int, default=600, help="env steps of the rollout")
    p.add_argument("--every", type=int, default=20, help="count every k-th step")
    p.add_argument("--seed", type=int, default=7)
    p.add_argument("--split", type=int, default=1, help="count the geoms as robot_collision_pieces=N would cut them (1: whole)")
    args = p.parse_args()
    for name in ("num_envs", "steps", "every", "split"):
        if getattr(args, name) < 1:
            raise SystemExit(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    state = read_checkpoint(args.checkpoint)
    cfg = OmegaConf.create(state["config"])
    if not is_parkour(cfg.env.name):
        raise SystemExit(f"checkpoint {args.checkpoint}: a run of env {cfg.env.name}, not of a Parkour env")
    device = torch.device("cpu")
    env = make_eval_env(cfg.env, args.num_envs, device, seed=args.seed)
    be = base_env(env)
    m, sim, scene = be.scene.mjm, be.sim, be.scene
    hf = scene.hfield_geom
    robot_geoms = [g for g in range(m.ngeom) if int(m.geom_contype[g]) & robot.ROBOT_BIT]
    kinds = {g: geom_kind(m, g) for g in robot_geoms}
    dataid = wp.to_torch(sim.model.geom_dataid).numpy()  # [batch, ngeom]
    fields = []
    for k in range(m.nhfield):
        nrow, ncol, adr = int(m.hfield_nrow[k]), int(m.hfield_ncol[k]), int(m.hfield_adr[k])
        fields.append((m.hfield_data[adr: adr + nrow * ncol].reshape(nrow, ncol) * m.hfield_size[k][2],
                       np.array(m.hfield_size[k])))
    policy = load_policy(state, env, device)
    torch.manual_seed(args.seed)  # the sampled actions
    task = be.task_id.numpy()
    counts = np.bincount(task, minlength=be.num_tasks)
    calls: dict[str, list[int]] = defaultdict(list)
    longest: dict[str, list[int]] = defaultdict(list)
    per_task = np.zeros(be.num_tasks)
    samples = 0
    td = env.reset()
    t0 = time.perf_counter()
    for t in range(args.steps):
        td.set("action", policy(td, False))
        _, td = env.step_and_maybe_reset(td)
        if (t + 1) % args.every:
            continue
        samples += 1
        xpos = sim.geom_xpos.numpy()
        xmat = wp.to_torch(sim.data.geom_xmat).numpy().reshape(sim.nworld, m.ngeom, 3, 3)
        step_max: dict[str, int] = defaultdict(int)
        for w in range(sim.nworld):
            heights, size = fields[int(dataid[w % dataid.shape[0], hf])]
            origin = xpos[w, hf]
            for g in robot_geoms:
                for centre, ext in pieces(m, g, xpos[w, g] - origin, xmat[w, g], args.split):
                    n = prism_calls(heights, size, centre - ext, centre + ext)
                    calls[kinds[g]].append(n)
                    step_max[kinds[g]] = max(step_max[kinds[g]], n)
                    per_task[task[w]] += n
        for kind, n in step_max.items():
            longest[kind].append(n)
    print(f"{sim.nworld} worlds over {be.num_tasks} task slots, {args.steps} env steps, counted every "
          f"{args.every} ({samples} samples), sampled actions, pieces per box/capsule {args.split}, CPU, "
          f"{time.perf_counter() - t0:.0f} s; "
          f"checkpoint {args.checkpoint}")
    total = sum(sum(v) for v in calls.values())
    print("| geom kind | pairs per world | GJK/EPA prisms per pair: mean | p99 | max | share of all prisms "
          "| longest pair per step (mean over samples) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for kind in sorted(calls, key=lambda k: -sum(calls[k])):
        v = np.array(calls[kind])
        pairs = sum(len(pieces(m, g, np.zeros(3), np.eye(3), args.split)) for g in robot_geoms if kinds[g] == kind)
        print(f"| {kind} | {pairs} | {v.mean():.2f} | {np.percentile(v, 99):.0f} | {v.max()} | "
              f"{100 * v.sum() / max(total, 1):.1f}% | {np.mean(longest[kind]):.1f} |")
    order = np.argsort(-per_task)
    print("prisms per world and sample, by terrain:",
          {be.task_names[i]: round(float(per_task[i]) / float(samples * counts[i]), 1) for i in order if counts[i]})
    env.close()


if __name__ == "__main__":
    main()
