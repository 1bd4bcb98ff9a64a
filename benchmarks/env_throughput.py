"""Full env steps per second of a batched mtbench env under random or scripted actions.

Measures everything an env step does: action -> mocap/ctrl, physics substeps (CUDA graphs), kinematics,
observation, reward, success, statistics, native autoreset, TensorDict out (``env.step_and_maybe_reset``).
On the GPU the env's torch stages replay CUDA graphs (``--eager-torch`` runs them op by op instead).

``--policy random`` (default) barely touches the objects. ``--policy scripted`` runs each task's scripted
controller for one episode (reach, grasp, push, press: the contact load of a trained policy); the env step is
then timed alone (synchronised before and after, the controller excluded), and contacts per world and the
success rate are reported. ``--robot-collision`` and ``--box-box`` select the collision geometry and collider.

Parkour settings (``--env parkour_flat|parkour_easy|parkour_hard|parkour_hard_cl`` or a terrain name) run the Go1
env with ``--policy trot`` (default for Parkour: the trot-in-place joint targets of ``parkour_collision.py``),
``stand`` (zero actions: hold the default pose) or ``random`` (uniform actions in [-1, 1] rad); the robots walk in
place on their tiles, fall, time out and reset as in training. ``--terrain-collision`` and
``--terrain-representation`` select the scene (``mtbench.envs.parkour.scene``), ``--num-rows`` the grid size,
``--robot-inertia``, ``--robot-armature`` and ``--robot-integrator`` the Go1's model (docs/parkour.md).

    python benchmarks/env_throughput.py --env mt10_rand --num-envs 24576 4096 --device cuda
    python benchmarks/env_throughput.py --env mt10_rand --num-envs 24576 --policy scripted
    python benchmarks/env_throughput.py --env parkour_hard --num-envs 16384
    python benchmarks/env_throughput.py --env mt50_rand --num-envs 24576 --phases   # compiled + grouped (its config)
    python benchmarks/env_throughput.py --env mt50_rand --num-envs 24576 --no-compile-stages --no-group-models
    python benchmarks/env_throughput.py --env reach,push,pick_place --num-envs 24576 --phases   # a custom task set

Meta-World settings with a Hydra env config (``conf/env/mt10*.yaml``, ``conf/env/mt50*.yaml``) are measured as
``env=<setting>`` builds them: ``compile_stages`` and ``group_models`` come from the config (``compile_stages:
auto`` = on for CUDA; MT50 groups its tasks, MT10 does not) unless ``--[no-]compile-stages`` / ``--[no-]group-models``
say otherwise; task lists default to neither. ``--compile-stages`` compiles the Meta-World env's torch stages (the
compile time is reported as "first step s"); ``--phases`` also times each part of a Meta-World step on its own (synchronised
before and after: the torch stages and the physics launches of every block), to show where a step's time goes.
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import torch
import warp as wp
from omegaconf import OmegaConf
from tensordict import TensorDictBase

from mtbench.envs import make_env
from mtbench.envs.metaworld.policies import scripted_policy
from mtbench.envs.parkour import robot as parkour_robot
from mtbench.envs.parkour.settings import SETTINGS as PARKOUR_SETTINGS
from mtbench.envs.parkour.terrains import TERRAIN_NAMES as PARKOUR_TERRAINS
from parkour_collision import TROT_HZ, controller_targets
from _timing import sync


def config_settings(env_name: str) -> dict[str, bool | str]:
    """``compile_stages`` (True, False or ``"auto"``: on for CUDA) and ``group_models`` of ``conf/env/<env_name>.yaml``,
    as ``env=<env_name>`` builds the env; ``{}`` for a name without such a config."""
    path = Path(__file__).resolve().parents[1] / "conf" / "env" / f"{env_name}.yaml"
    if is_parkour(env_name) or not path.is_file():
        return {}
    overrides = OmegaConf.load(path).get("overrides") or {}
    return {"compile_stages": overrides.get("compile_stages", False), "group_models": overrides.get("group_models", False)}


def is_parkour(env_name: str) -> bool:
    return env_name in PARKOUR_SETTINGS or env_name in PARKOUR_TERRAINS


def _contacts_per_world(env) -> float:
    sims = [env.sim] if hasattr(env, "sim") else env.sims
    return sum(float(wp.to_torch(sim.data.nacon)[0]) for sim in sims) / env.batch_size[0]


def run_scripted(env, warmup: int) -> tuple[float, int, float, TensorDictBase]:
    """One episode of the scripted controllers: seconds in the env steps after ``warmup``, timed steps, mean
    contacts per world, episode statistics."""
    policies = [scripted_policy(t) for t in env.task_names]
    td = env.reset()
    elapsed, contacts = 0.0, []
    for i in range(env.max_episode_steps):
        obs = td["observation"][:, : env.state_dim]
        td["action"] = torch.cat([p(obs[sl]) for p, sl in zip(policies, env.slices)])
        sync(env.device)
        t0 = time.perf_counter()
        _, td = env.step_and_maybe_reset(td)
        sync(env.device)
        if i >= warmup:
            elapsed += time.perf_counter() - t0
            contacts.append(_contacts_per_world(env))
    return elapsed, len(contacts), sum(contacts) / len(contacts), env.pop_episode_stats()


def _actions(env, policy: str, count: int) -> torch.Tensor:
    """``[count, N, A]`` actions: uniform in [-1, 1] (``random``), zero (``stand``) or the Parkour trot cycle."""
    n, dim = env.batch_size[0], env.action_spec.shape[-1]
    if policy == "random":
        gen = torch.Generator(device=env.device).manual_seed(0)
        return torch.rand(count, n, dim, generator=gen, device=env.device) * 2 - 1
    if policy == "stand":
        return torch.zeros(count, n, dim, device=env.device)
    cycle = int(round(1.0 / (TROT_HZ * 0.02)))
    offsets = (controller_targets("trot", cycle).to(env.device) - env.q_default)[None].expand(n, -1, -1)
    return offsets.permute(1, 0, 2).repeat(count // cycle + 1, 1, 1)[:count].contiguous()


def run_timed(env, steps: int, warmup: int, policy: str = "random") -> tuple[float, int, float, TensorDictBase]:
    """``warmup`` + ``steps`` steps of precomputed actions, timed as a whole after the warm-up."""
    td = env.reset()
    actions = _actions(env, policy, warmup + steps)
    for i in range(warmup):
        td["action"] = actions[i]
        _, td = env.step_and_maybe_reset(td)
    sync(env.device)
    t0 = time.perf_counter()
    for i in range(steps):
        td["action"] = actions[warmup + i]
        _, td = env.step_and_maybe_reset(td)
    sync(env.device)
    elapsed = time.perf_counter() - t0
    return elapsed, steps, _contacts_per_world(env), env.pop_episode_stats()


def phase_times(env, steps: int) -> dict[str, float]:
    """Milliseconds per step of each part of a Meta-World env step (``env.step_parts``, the sequence
    ``_core_step`` runs), each synchronised before and after, over ``steps`` steps of random actions (after the
    stages are captured)."""
    totals = {name: 0.0 for name, _ in env.step_parts}
    gen = torch.Generator(device=env.device).manual_seed(1)
    for _ in range(steps):
        env._action_in.copy_(torch.rand(env._action_in.shape, generator=gen, device=env.device) * 2 - 1)
        for name, part in env.step_parts:
            sync(env.device)
            t0 = time.perf_counter()
            part()
            sync(env.device)
            totals[name] += time.perf_counter() - t0
    return {name: 1e3 * t / steps for name, t in totals.items()}


def measure(env_name: str, num_envs: int, device: str, steps: int, warmup: int, substeps: int | None,
            parallel_streams: bool = True, torch_graphs: bool = True, policy: str = "random",
            robot_collision: str = "primitive", box_box: str = "primitive",
            terrain_collision: str = parkour_robot.DEFAULT_TERRAIN_COLLISION, terrain_representation: str = "grid",
            num_rows: int = 10, compile_stages: bool | str = False, phases: bool = False, group_models: bool = False,
            robot_joints: tuple[str, float | None, str] = (parkour_robot.DEFAULT_INERTIAL_MODEL, None,
                                                           parkour_robot.DEFAULT_INTEGRATOR),
            robot_contact: float | None = parkour_robot.DEFAULT_CONTACT_TIMECONST,
            robot_pieces: int = parkour_robot.DEFAULT_COLLISION_PIECES) -> dict:
    parkour = is_parkour(env_name)
    if parkour:
        if policy == "scripted":
            raise ValueError("--policy scripted is for Meta-World; Parkour takes trot, stand or random")
        inertia, armature, integrator = robot_joints
        overrides = {"torch_graphs": torch_graphs, "terrain_collision": terrain_collision,
                     "terrain_representation": terrain_representation, "num_rows": num_rows,
                     "robot_inertia": inertia, "robot_armature": armature, "robot_integrator": integrator,
                     "robot_contact_timeconst": robot_contact, "robot_collision_pieces": robot_pieces}
        collision = f"{terrain_collision} on {terrain_representation}"
        if robot_joints != (parkour_robot.DEFAULT_INERTIAL_MODEL, None, parkour_robot.DEFAULT_INTEGRATOR):
            collision += f"; {inertia}, armature {parkour_robot.joint_armature(inertia, armature):g}, {integrator}"
        if robot_contact != parkour_robot.DEFAULT_CONTACT_TIMECONST:
            collision += f"; contacts {'MuJoCo soft 0.02' if robot_contact is None else f'{robot_contact:g}'} s"
        if robot_pieces != parkour_robot.DEFAULT_COLLISION_PIECES:
            collision += f"; {robot_pieces} pieces per box/long capsule"
    else:
        if policy in ("trot", "stand"):
            raise ValueError(f"--policy {policy} is for Parkour; Meta-World takes random or scripted")
        overrides = {"parallel_streams": parallel_streams, "torch_graphs": torch_graphs,
                     "robot_collision": robot_collision, "box_box_collider": box_box, "compile_stages": compile_stages,
                     "group_models": group_models}
        collision = f"{robot_collision} hand, {box_box} box-box"
        if substeps is not None:
            overrides["substeps"] = substeps
    if policy == "scripted":
        overrides["random_start_progress"] = False  # every world runs exactly one episode
    t0 = time.perf_counter()
    tasks = env_name.split(",") if "," in env_name else env_name  # a comma-separated list: its own task set
    env = make_env(tasks, num_envs=num_envs, device=device, seed=0, **overrides)
    build_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    td = env.reset()
    td["action"] = torch.zeros(env.action_spec.shape, device=env.device)
    env.step_and_maybe_reset(td)
    sync(env.device)
    first_step_s = time.perf_counter() - t0
    if policy == "scripted":
        elapsed, steps, contacts, stats = run_scripted(env, warmup)
        success = float((stats["success"] / stats["episodes"].clamp_min(1)).mean())
    else:
        elapsed, steps, contacts, stats = run_timed(env, steps, warmup, policy)
        success = float("nan")
    mode = "torch stages graphed" if torch_graphs and env.device.type == "cuda" else "torch stages eager"
    if getattr(env, "compile_stages", False):
        mode += ", compiled"
    if not parkour:
        mode += ", block streams" if parallel_streams else ", one stream"
        mode += f", {len(env.sims)} physics blocks" + (" (grouped models)" if group_models else "")
    sim_substeps = env.sim.substeps if parkour else env.blocks[0][1].sim.substeps
    return {
        "env": env_name,
        "num_envs": num_envs,
        "substeps": sim_substeps,
        "env_steps_per_s": num_envs * steps / elapsed,
        "physics_steps_per_s": num_envs * steps * sim_substeps / elapsed,
        "ms_per_step": 1e3 * elapsed / steps,
        "build_s": build_s,
        "unhealthy_resets": float(stats["unhealthy"].sum()),
        "mode": mode,
        "policy": policy,
        "collision": collision,
        "contacts_per_world": contacts,
        "success": success,
        "first_step_s": first_step_s,
        "phases": phase_times(env, steps) if phases and not parkour else None,
    }


def _seconds_or_null(value: str) -> float | None:
    """``--robot-contact-timeconst``: a number of seconds, or ``null`` (MuJoCo's own time constant)."""
    if value == "null":
        return None
    try:
        return float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number of seconds or null, got {value!r}") from None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="mt10_rand",
                        help="a setting (mt10_rand, mt50_rand, parkour_hard, ...), a task or terrain name, or a "
                             "comma-separated list of Meta-World tasks (worlds split evenly)")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[4096, 24576])
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--steps", type=int, default=300, help="timed steps (random policy; scripted: one episode)")
    parser.add_argument("--warmup", type=int, default=20)
    parser.add_argument("--substeps", type=int, default=None)
    parser.add_argument("--one-stream", action="store_true", help="all task blocks on one CUDA stream")
    parser.add_argument("--eager-torch", action="store_true", help="do not capture the env's torch stages")
    parser.add_argument("--policy", choices=("random", "scripted", "trot", "stand"), default=None,
                        help="scripted: one episode of each Meta-World task's scripted controller (contact-rich); "
                             "trot / stand: Parkour controllers (default: random for Meta-World, trot for Parkour)")
    parser.add_argument("--robot-collision", choices=("primitive", "mesh"), default="primitive")
    parser.add_argument("--box-box", choices=("primitive", "gjk"), default="primitive")
    parser.add_argument("--terrain-collision", choices=parkour_robot.TERRAIN_COLLISIONS,
                        default=parkour_robot.DEFAULT_TERRAIN_COLLISION,
                        help="Parkour: robot geoms that touch the terrain")
    parser.add_argument("--terrain-representation", choices=("tiles", "grid"), default="tiles",
                        help="Parkour: one heightfield per tile (default) or one for the whole grid")
    parser.add_argument("--num-rows", type=int, default=10, help="Parkour: difficulty rows of the terrain grid")
    parser.add_argument("--robot-inertia", choices=parkour_robot.INERTIAL_MODELS,
                        default=parkour_robot.DEFAULT_INERTIAL_MODEL, help="Parkour: the Go1's inertial model")
    parser.add_argument("--robot-armature", type=float, default=None,
                        help="Parkour: joint armature in kg m^2 (default: the inertial model's)")
    parser.add_argument("--robot-integrator", choices=tuple(parkour_robot.INTEGRATORS),
                        default=parkour_robot.DEFAULT_INTEGRATOR, help="Parkour: euler or implicitfast")
    parser.add_argument("--robot-contact-timeconst", type=_seconds_or_null,
                        default=parkour_robot.DEFAULT_CONTACT_TIMECONST,
                        help="Parkour: the robot's contact time constant in s, or null for MuJoCo's soft 0.02 "
                             f"(default {parkour_robot.DEFAULT_CONTACT_TIMECONST:g})")
    parser.add_argument("--robot-collision-pieces", type=int, default=parkour_robot.DEFAULT_COLLISION_PIECES,
                        help="Parkour: each box and long capsule of the robot's collision set as N pieces "
                             f"(default {parkour_robot.DEFAULT_COLLISION_PIECES}; docs/parkour.md)")
    parser.add_argument("--compile-stages", action=argparse.BooleanOptionalAction, default=None,
                        help="Meta-World: torch.compile the env's torch stages (default: the env config's setting)")
    parser.add_argument("--group-models", action=argparse.BooleanOptionalAction, default=None,
                        help="Meta-World: tasks whose models MuJoCo Warp can batch share one model (group_models=True; "
                             "default: the env config's setting)")
    parser.add_argument("--phases", action="store_true",
                        help="Meta-World: also time each part of a step on its own (ms per step)")
    args = parser.parse_args()
    if args.policy is None:
        args.policy = "trot" if is_parkour(args.env) else "random"
    configured = config_settings(args.env)
    for key in ("compile_stages", "group_models"):
        if getattr(args, key) is None:
            setattr(args, key, configured.get(key, False))
    if configured:
        print(f"settings: compile_stages={args.compile_stages!r} ('auto': on for CUDA), group_models={args.group_models} "
              f"(conf/env/{args.env}.yaml unless --[no-]compile-stages / --[no-]group-models say otherwise)")
    name = torch.cuda.get_device_name() if args.device.startswith("cuda") else platform.processor() or "cpu"
    print(f"device: {name}; torch {torch.__version__}; date {time.strftime('%Y-%m-%d')}")
    print("| env | envs | policy | collision | mode | substeps | env steps/s | physics steps/s | ms/step | "
          "contacts/world | success | build s | first step s | unhealthy resets |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.num_envs:
        r = measure(args.env, n, args.device, args.steps, args.warmup, args.substeps,
                    parallel_streams=not args.one_stream, torch_graphs=not args.eager_torch, policy=args.policy,
                    robot_collision=args.robot_collision, box_box=args.box_box,
                    terrain_collision=args.terrain_collision, terrain_representation=args.terrain_representation,
                    num_rows=args.num_rows, compile_stages=args.compile_stages, phases=args.phases,
                    group_models=args.group_models, robot_joints=(args.robot_inertia, args.robot_armature, args.robot_integrator),
                    robot_contact=args.robot_contact_timeconst, robot_pieces=args.robot_collision_pieces)
        print(f"| {r['env']} | {r['num_envs']} | {r['policy']} | {r['collision']} | {r['mode']} | {r['substeps']} | "
              f"{r['env_steps_per_s']:,.0f} | {r['physics_steps_per_s']:,.0f} | {r['ms_per_step']:.2f} | "
              f"{r['contacts_per_world']:.2f} | {r['success']:.1%} | {r['build_s']:.1f} | {r['first_step_s']:.1f} | "
              f"{r['unhealthy_resets']:.0f} |", flush=True)
        if r["phases"] is not None:
            total = sum(r["phases"].values())
            print("  parts of a step, each synchronised (ms): " + ", ".join(
                f"{name} {ms:.2f}" for name, ms in r["phases"].items()) + f"; sum {total:.2f}", flush=True)


if __name__ == "__main__":
    main()
