"""Why Parkour worlds fail their physics: run a trained policy and count, per cause, the worlds the env resets as
unhealthy (non-finite state, runaway joint or base velocity above 1e4, fatal buffer overflow), per physics setting.

A setting is the robot's contact time constant (seconds, or ``null`` for MuJoCo's soft 0.02 s), optionally followed
by ``@N`` (the Newton solver's iteration cap instead of ``scene.SOLVER_ITERATIONS``) and ``#K`` (MuJoCo's
``ccd_iterations``, the GJK/EPA cap of the heightfield collisions, instead of ``scene.CCD_ITERATIONS``). Actions are
sampled as in training. Also printed: wall time per env step (the settings run one after another in one process) and
the share of world-steps with a non-fatal heightfield overflow (a geom on more than 50 prisms).

    python benchmarks/parkour_unhealthy.py CHECKPOINT --num-envs 4096 --steps 1000 0.01 0.01@30 0.01#12 0.012 null

Results: docs/parkour.md, "Contact stiffness".
"""

from __future__ import annotations

import argparse
import time

import mujoco_warp as mjw
import torch
from omegaconf import OmegaConf

from mtbench.envs.make import is_parkour
from mtbench.envs.parkour import scene as parkour_scene
from mtbench.evaluation.policy import load_policy, make_eval_env, read_checkpoint
from mtbench.trainer.rollout import base_env

def parse_setting(text: str) -> tuple[float | None, int, int]:
    """``"0.01@30#12"`` -> (0.01, 30, 12); missing parts take the scene's defaults."""
    rest, _, ccd = text.partition("#")
    value, _, solver = rest.partition("@")
    try:
        contact = None if value == "null" else float(value)
        return (contact, int(solver) if solver else parkour_scene.SOLVER_ITERATIONS,
                int(ccd) if ccd else parkour_scene.CCD_ITERATIONS)
    except ValueError:
        raise SystemExit(f"setting {text!r}: expected CONTACT[@SOLVER_ITERATIONS][#CCD_ITERATIONS], CONTACT a number "
                         "of seconds or null, e.g. 0.01@30#12") from None


def run(state: dict, setting: str, num_envs: int, steps: int, device: torch.device, seed: int) -> dict:
    contact, solver, ccd = parse_setting(setting)
    defaults = parkour_scene.SOLVER_ITERATIONS, parkour_scene.CCD_ITERATIONS
    parkour_scene.SOLVER_ITERATIONS, parkour_scene.CCD_ITERATIONS = solver, ccd
    try:
        cfg = OmegaConf.create(state["config"])
        cfg.env.overrides.robot_contact_timeconst = contact
        env = make_eval_env(cfg.env, num_envs, device, seed=seed)
    finally:
        parkour_scene.SOLVER_ITERATIONS, parkour_scene.CCD_ITERATIONS = defaults
    be = base_env(env)
    opt = be.scene.mjm.opt
    assert (int(opt.iterations), int(opt.ccd_iterations)) == (solver, ccd), "the scene ignored the setting"
    sim = be.sim
    causes = torch.zeros(3, device=device)  # non-finite, runaway, fatal overflow (a world may have several)
    hfield = torch.zeros((), device=device)
    per_task = torch.zeros(be.num_tasks, device=device)
    task = be.task_id.long()
    env_step = be._step
    in_step = [False]

    def counted_unhealthy(*args, **kwargs) -> torch.Tensor:  # WarpSim.unhealthy, counting its causes
        nonfinite, runaway, fatal = sim.unhealthy_causes(*args, **kwargs).values()
        bad = nonfinite | runaway | fatal
        if in_step[0]:  # once per env step (the env's resets call it again for the worlds they reset)
            causes.add_(torch.stack([nonfinite.sum(), runaway.sum(), fatal.sum()]).float())
            hfield.add_(((sim._overflow & int(mjw.OverflowType.HFIELD)) != 0).sum())
            per_task.index_add_(0, task, bad.float())
        return bad

    def counted_step(td):
        in_step[0] = True
        try:
            return env_step(td)
        finally:
            in_step[0] = False

    sim.unhealthy, be._step = counted_unhealthy, counted_step
    policy = load_policy(state, env, device)
    torch.manual_seed(seed)  # the sampled actions
    td = env.reset()
    for _ in range(10):  # warm-up (graph capture) outside the timing
        td.set("action", policy(td, False))
        _, td = env.step_and_maybe_reset(td)
    be.pop_episode_stats()
    causes.zero_(), hfield.zero_(), per_task.zero_()
    if device.type == "cuda":
        torch.cuda.synchronize()
    t0 = time.perf_counter()
    for _ in range(steps):
        td.set("action", policy(td, False))
        _, td = env.step_and_maybe_reset(td)
    if device.type == "cuda":
        torch.cuda.synchronize()
    wall = time.perf_counter() - t0
    resets = float(be.pop_episode_stats()["unhealthy"].sum())
    world_steps = steps * num_envs
    env.close()
    c = causes.tolist()
    return {"setting": setting, "contact": "MuJoCo 0.02" if contact is None else f"{contact:g}", "solver": solver,
            "ccd": ccd, "ms": 1e3 * wall / steps, "resets": resets, "per_m": resets / (world_steps / 1e6),
            "nonfinite": c[0], "runaway": c[1], "fatal": c[2], "hfield": float(hfield) / world_steps,
            "tasks": {be.task_names[i]: int(v) for i, v in enumerate(per_task.tolist()) if v > 0}}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("checkpoint", help="a Parkour training checkpoint (full or slim)")
    p.add_argument("settings", nargs="+",
                   help="CONTACT[@SOLVER_ITERATIONS][#CCD_ITERATIONS], e.g. 0.01 null 0.01@30")
    p.add_argument("--num-envs", type=int, default=4096)
    p.add_argument("--steps", type=int, default=1000, help="timed env steps per setting")
    p.add_argument("--device", default="auto")
    p.add_argument("--seed", type=int, default=7)
    args = p.parse_args()
    for s in args.settings:
        parse_setting(s)  # every setting checked before the first run
    device = torch.device(("cuda" if torch.cuda.is_available() else "cpu") if args.device == "auto" else args.device)
    state = read_checkpoint(args.checkpoint)
    env_name = OmegaConf.create(state["config"]).env.name
    if not is_parkour(env_name):
        raise SystemExit(f"checkpoint {args.checkpoint}: a run of env {env_name}, not of a Parkour env")
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else "cpu"
    print(f"device: {name}; torch {torch.__version__}; {time.strftime('%Y-%m-%d')}; {args.num_envs} worlds x "
          f"{args.steps} steps per setting; checkpoint {args.checkpoint}")
    print("| contacts (s) | solver iterations | ccd iterations | ms per env step | unhealthy resets "
          "| per M world-steps | non-finite / runaway / fatal overflow (world-steps) "
          "| non-fatal HFIELD overflow (share of world-steps) |")
    print("|---|---:|---:|---:|---:|---:|---|---:|")
    rows = []
    for s in args.settings:
        r = run(state, s, args.num_envs, args.steps, device, args.seed)
        rows.append(r)
        print(f"| {r['contact']} | {r['solver']} | {r['ccd']} | {r['ms']:.1f} | {r['resets']:.0f} | {r['per_m']:.2f} | "
              f"{r['nonfinite']:.0f} / {r['runaway']:.0f} / {r['fatal']:.0f} | {100 * r['hfield']:.2f}% |", flush=True)
    for r in rows:
        print(f"{r['setting']}: unhealthy per task {r['tasks']}")


if __name__ == "__main__":
    main()
