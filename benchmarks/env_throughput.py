"""Full env steps per second of a batched mtbench env under random or scripted actions.

Measures everything an env step does: action -> mocap/ctrl, physics substeps (CUDA graphs), kinematics,
observation, reward, success, statistics, native autoreset, TensorDict out (``env.step_and_maybe_reset``).
On the GPU the env's torch stages replay CUDA graphs (``--eager-torch`` runs them op by op instead).

``--policy random`` (default) barely touches the objects. ``--policy scripted`` runs each task's scripted
controller for one episode (reach, grasp, push, press: the contact load of a trained policy); the env step is
then timed alone (synchronised before and after, the controller excluded), and contacts per world and the
success rate are reported. ``--robot-collision`` and ``--box-box`` select the collision geometry and collider.

    python benchmarks/env_throughput.py --env mt10_rand --num-envs 24576 4096 --device cuda
    python benchmarks/env_throughput.py --env mt10_rand --num-envs 24576 --policy scripted
"""

from __future__ import annotations

import argparse
import platform
import time

import torch
import warp as wp
from tensordict import TensorDictBase

from mtbench.envs import make_env
from mtbench.envs.metaworld.policies import scripted_policy


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def _contacts_per_world(env) -> float:
    return sum(float(wp.to_torch(s.sim.data.nacon)[0]) for _, s in env.blocks) / env.batch_size[0]


def run_scripted(env, warmup: int) -> tuple[float, int, float, TensorDictBase]:
    """One episode of the scripted controllers: seconds in the env steps after ``warmup``, timed steps, mean
    contacts per world, episode statistics."""
    policies = [scripted_policy(t) for t in env.task_names]
    td = env.reset()
    elapsed, contacts = 0.0, []
    for i in range(env.max_episode_steps):
        obs = td["observation"][:, : env.state_dim]
        td["action"] = torch.cat([p(obs[sl]) for p, sl in zip(policies, env.slices)])
        _sync(env.device)
        t0 = time.perf_counter()
        _, td = env.step_and_maybe_reset(td)
        _sync(env.device)
        if i >= warmup:
            elapsed += time.perf_counter() - t0
            contacts.append(_contacts_per_world(env))
    return elapsed, len(contacts), sum(contacts) / len(contacts), env.pop_episode_stats()


def run_random(env, steps: int, warmup: int) -> tuple[float, int, float, TensorDictBase]:
    """``warmup`` + ``steps`` steps of uniform random actions, timed as a whole after the warm-up."""
    td = env.reset()
    gen = torch.Generator(device=env.device).manual_seed(0)
    actions = torch.rand(warmup + steps, env.batch_size[0], 4, generator=gen, device=env.device) * 2 - 1
    for i in range(warmup):
        td["action"] = actions[i]
        _, td = env.step_and_maybe_reset(td)
    _sync(env.device)
    t0 = time.perf_counter()
    for i in range(steps):
        td["action"] = actions[warmup + i]
        _, td = env.step_and_maybe_reset(td)
    _sync(env.device)
    elapsed = time.perf_counter() - t0
    return elapsed, steps, _contacts_per_world(env), env.pop_episode_stats()


def measure(env_name: str, num_envs: int, device: str, steps: int, warmup: int, substeps: int | None,
            parallel_streams: bool = True, torch_graphs: bool = True, policy: str = "random",
            robot_collision: str = "primitive", box_box: str = "primitive") -> dict:
    overrides = {"parallel_streams": parallel_streams, "torch_graphs": torch_graphs,
                 "robot_collision": robot_collision, "box_box_collider": box_box}
    if substeps is not None:
        overrides["substeps"] = substeps
    if policy == "scripted":
        overrides["random_start_progress"] = False  # every world runs exactly one episode
    t0 = time.perf_counter()
    env = make_env(env_name, num_envs=num_envs, device=device, seed=0, **overrides)
    build_s = time.perf_counter() - t0
    if policy == "scripted":
        elapsed, steps, contacts, stats = run_scripted(env, warmup)
        success = float((stats["success"] / stats["episodes"].clamp_min(1)).mean())
    else:
        elapsed, steps, contacts, stats = run_random(env, steps, warmup)
        success = float("nan")
    mode = ("torch stages graphed" if torch_graphs and env.device.type == "cuda" else "torch stages eager") + (
        ", block streams" if parallel_streams else ", one stream")
    return {
        "env": env_name,
        "num_envs": num_envs,
        "substeps": env.blocks[0][1].sim.substeps,
        "env_steps_per_s": num_envs * steps / elapsed,
        "physics_steps_per_s": num_envs * steps * env.blocks[0][1].sim.substeps / elapsed,
        "ms_per_step": 1e3 * elapsed / steps,
        "build_s": build_s,
        "unhealthy_resets": float(stats["unhealthy"].sum()),
        "mode": mode,
        "policy": policy,
        "collision": f"{robot_collision} hand, {box_box} box-box",
        "contacts_per_world": contacts,
        "success": success,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="mt10_rand")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[4096, 24576])
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--steps", type=int, default=300, help="timed steps (random policy; scripted: one episode)")
    parser.add_argument("--warmup", type=int, default=20)
    parser.add_argument("--substeps", type=int, default=None)
    parser.add_argument("--one-stream", action="store_true", help="all task blocks on one CUDA stream")
    parser.add_argument("--eager-torch", action="store_true", help="do not capture the env's torch stages")
    parser.add_argument("--policy", choices=("random", "scripted"), default="random",
                        help="scripted: one episode of each task's scripted controller (contact-rich)")
    parser.add_argument("--robot-collision", choices=("primitive", "mesh"), default="primitive")
    parser.add_argument("--box-box", choices=("primitive", "gjk"), default="primitive")
    args = parser.parse_args()
    name = torch.cuda.get_device_name() if args.device.startswith("cuda") else platform.processor() or "cpu"
    print(f"device: {name}; torch {torch.__version__}; date {time.strftime('%Y-%m-%d')}")
    print("| env | envs | policy | collision | mode | substeps | env steps/s | physics steps/s | ms/step | "
          "contacts/world | success | build s | unhealthy resets |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.num_envs:
        r = measure(args.env, n, args.device, args.steps, args.warmup, args.substeps,
                    parallel_streams=not args.one_stream, torch_graphs=not args.eager_torch, policy=args.policy,
                    robot_collision=args.robot_collision, box_box=args.box_box)
        print(f"| {r['env']} | {r['num_envs']} | {r['policy']} | {r['collision']} | {r['mode']} | {r['substeps']} | "
              f"{r['env_steps_per_s']:,.0f} | {r['physics_steps_per_s']:,.0f} | {r['ms_per_step']:.2f} | "
              f"{r['contacts_per_world']:.2f} | {r['success']:.1%} | {r['build_s']:.1f} | "
              f"{r['unhealthy_resets']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
