"""Parameter count and forward(+backward) time of every registered architecture at its MT10 preset sizes.

Usage::

    python benchmarks/modules_speed.py --device cuda            # batch 32768, median of 20 timed steps
    python benchmarks/modules_speed.py --device cpu --batch 256 --repeats 3

Each architecture is built from ``conf/arch/<name>.yaml`` (actor role, ``out_dim`` = Meta-World's 4 action dims)
for MT10 (state 39 + one-hot 10) and timed on a batch mixing all tasks. ``fwd+bwd`` is one forward, a scalar loss
and ``backward()`` (gradients reset with ``set_to_none``); ``fwd (no_grad)`` is the rollout-time inference cost.
On CUDA every timed step is bracketed by ``torch.cuda.synchronize()``. Prints a markdown table.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import torch
from omegaconf import OmegaConf

from mtbench.envs.metaworld import MT10, TASKS
from mtbench.modules import ARCHITECTURES, arch_kwargs, make_network
from _timing import median_ms

CONF_DIR = Path(__file__).resolve().parents[1] / "conf" / "arch"


def build(arch: str, num_tasks: int, state_dim: int, out_dim: int, device: torch.device) -> torch.nn.Module:
    preset = CONF_DIR / f"{arch}.yaml"
    name, kwargs = arch_kwargs(OmegaConf.load(preset), "actor") if preset.exists() else (arch, {})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # CARE warns when it falls back to learned task embeddings
        net = make_network(
            name, obs_dim=state_dim + num_tasks, out_dim=out_dim, num_tasks=num_tasks,
            task_descriptions=[TASKS[t].description for t in MT10[:num_tasks]], **kwargs
        )
    return net.to(device)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--batch", type=int, default=32768)
    parser.add_argument("--repeats", type=int, default=20, help="timed steps (median reported)")
    parser.add_argument("--warmup", type=int, default=3)
    parser.add_argument("--num-tasks", type=int, default=10, help="<= 10 (MT10 task names)")
    parser.add_argument("--state-dim", type=int, default=39)
    parser.add_argument("--out-dim", type=int, default=4)
    parser.add_argument("--archs", nargs="*", default=list(ARCHITECTURES), help="subset of the registered names")
    args = parser.parse_args()
    device = torch.device(args.device)
    if not 1 <= args.num_tasks <= len(MT10):
        raise ValueError(f"--num-tasks must be in 1..{len(MT10)}, got {args.num_tasks}")
    unknown = sorted(set(args.archs) - set(ARCHITECTURES))
    if unknown:
        raise ValueError(f"unknown archs {unknown}; valid choices: {sorted(ARCHITECTURES)}")

    gen = torch.Generator().manual_seed(0)
    task_id = torch.arange(args.batch) % args.num_tasks
    obs = torch.cat(
        [torch.randn(args.batch, args.state_dim, generator=gen), torch.nn.functional.one_hot(task_id, args.num_tasks).float()],
        dim=-1,
    ).to(device)
    task_id = task_id.to(device)

    label = torch.cuda.get_device_name(device) if device.type == "cuda" else f"cpu ({torch.get_num_threads()} threads)"
    print(f"MT{args.num_tasks} sizes, batch {args.batch}, out_dim {args.out_dim}, {label}, torch {torch.__version__}, "
          f"median of {args.repeats}\n")
    print("| arch | parameters | fwd+bwd (ms) | fwd no_grad (ms) |")
    print("|---|---:|---:|---:|")
    for arch in args.archs:
        net = build(arch, args.num_tasks, args.state_dim, args.out_dim, device)
        n_params = sum(p.numel() for p in net.parameters() if p.requires_grad)

        def train_step() -> None:
            net.zero_grad(set_to_none=True)
            net(obs, task_id).square().mean().backward()

        def infer_step() -> None:
            with torch.no_grad():
                net(obs, task_id)

        t_train = median_ms(train_step, device, args.repeats, warmup=args.warmup)
        t_infer = median_ms(infer_step, device, args.repeats, warmup=args.warmup)
        print(f"| {arch} | {n_params:,} | {t_train:.2f} | {t_infer:.2f} |")
        if device.type == "cuda":
            torch.cuda.empty_cache()


if __name__ == "__main__":
    main()
