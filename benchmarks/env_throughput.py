"""Full env steps per second of a batched mtbench env under random actions.

Measures everything an env step does: action -> mocap/ctrl, physics substeps (CUDA graphs), kinematics,
observation, reward, success, statistics, native autoreset, TensorDict out (``env.step_and_maybe_reset``).
On the GPU the env's torch stages replay CUDA graphs (``--eager-torch`` runs them op by op instead).

    python benchmarks/env_throughput.py --env mt10_rand --num-envs 24576 4096 --device cuda
"""

from __future__ import annotations

import argparse
import platform
import time

import torch

from mtbench.envs import make_env


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def measure(env_name: str, num_envs: int, device: str, steps: int, warmup: int, substeps: int | None,
            parallel_streams: bool = True, torch_graphs: bool = True) -> dict:
    overrides = {"parallel_streams": parallel_streams, "torch_graphs": torch_graphs}
    if substeps is not None:
        overrides["substeps"] = substeps
    t0 = time.perf_counter()
    env = make_env(env_name, num_envs=num_envs, device=device, seed=0, **overrides)
    build_s = time.perf_counter() - t0
    dev = env.device
    td = env.reset()
    gen = torch.Generator(device=dev).manual_seed(0)
    actions = torch.rand(warmup + steps, num_envs, 4, generator=gen, device=dev) * 2 - 1
    for i in range(warmup):
        td["action"] = actions[i]
        _, td = env.step_and_maybe_reset(td)
    _sync(dev)
    t0 = time.perf_counter()
    for i in range(steps):
        td["action"] = actions[warmup + i]
        _, td = env.step_and_maybe_reset(td)
    _sync(dev)
    elapsed = time.perf_counter() - t0
    stats = env.pop_episode_stats()
    return {
        "env": env_name,
        "num_envs": num_envs,
        "substeps": env.blocks[0][1].sim.substeps,
        "env_steps_per_s": num_envs * steps / elapsed,
        "physics_steps_per_s": num_envs * steps * env.blocks[0][1].sim.substeps / elapsed,
        "ms_per_step": 1e3 * elapsed / steps,
        "build_s": build_s,
        "unhealthy_resets": float(stats["unhealthy"].sum()),
        "mode": ("torch stages graphed" if torch_graphs and dev.type == "cuda" else "torch stages eager")
        + (", block streams" if parallel_streams else ", one stream"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="mt10_rand")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[4096, 24576])
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--warmup", type=int, default=20)
    parser.add_argument("--substeps", type=int, default=None)
    parser.add_argument("--one-stream", action="store_true", help="all task blocks on one CUDA stream")
    parser.add_argument("--eager-torch", action="store_true", help="do not capture the env's torch stages")
    args = parser.parse_args()
    name = torch.cuda.get_device_name() if args.device.startswith("cuda") else platform.processor() or "cpu"
    print(f"device: {name}; torch {torch.__version__}; date {time.strftime('%Y-%m-%d')}")
    print("| env | envs | mode | substeps | env steps/s | physics steps/s | ms/step | build s | unhealthy resets |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.num_envs:
        r = measure(args.env, n, args.device, args.steps, args.warmup, args.substeps,
                    parallel_streams=not args.one_stream, torch_graphs=not args.eager_torch)
        print(f"| {r['env']} | {r['num_envs']} | {r['mode']} | {r['substeps']} | {r['env_steps_per_s']:,.0f} | "
              f"{r['physics_steps_per_s']:,.0f} | {r['ms_per_step']:.2f} | {r['build_s']:.1f} | "
              f"{r['unhealthy_resets']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
