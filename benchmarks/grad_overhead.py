"""Cost of gradient manipulation: time of one MT-PPO update per gradient method.

One update = wrapper/loss forward + backward (per-task gradients and manipulation where applicable) +
global grad-norm clip + Adam step, on a random minibatch, with mtbench's MT-PPO loss (``MTPPOLoss``) and the
paper's vanilla MLP actor/critic ([256, 128, 64], ELU) on observations of 39 + K dims. Prints a markdown table.

    python benchmarks/grad_overhead.py --device cuda                      # paper sizes: K = 10, 50; 16384
    python benchmarks/grad_overhead.py --device cpu --minibatch 512 --tasks 3 10 --iters 3   # smoke run
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from typing import Any

import torch
from tensordict import TensorDict

from mtbench.objectives import MTPPOLoss, compute_gradients, make_gradient_method
from mtbench.trainer.actor_critic import make_actor, make_critic
from _timing import sync

STATE_DIM, ACTION_DIM = 39, 4
METHODS = ("none", "pcgrad", "cagrad", "famo")


def make_setup(num_tasks: int, minibatch: int, hidden: list[int], device: torch.device, seed: int = 0):
    torch.manual_seed(seed)
    arch = {"name": "mlp", "kwargs": {"hidden": hidden, "activation": "elu"}}
    obs_dim = STATE_DIM + num_tasks
    actor = make_actor(arch, obs_dim=obs_dim, action_dim=ACTION_DIM, num_tasks=num_tasks, device=device)
    critic = make_critic(arch, obs_dim=obs_dim, num_tasks=num_tasks, device=device)
    loss = MTPPOLoss(actor, critic, num_tasks=num_tasks).to(device)
    task_id = torch.arange(minibatch, device=device) % num_tasks
    obs = torch.cat(
        [
            torch.randn(minibatch, STATE_DIM, device=device),
            torch.nn.functional.one_hot(task_id, num_tasks).float(),
        ],
        -1,
    )
    batch = TensorDict({"observation": obs, "task_id": task_id}, batch_size=[minibatch], device=device)
    with torch.no_grad():
        actor(batch)
    batch["advantage"] = torch.randn(minibatch, 1, device=device)
    batch["value_target"] = torch.randn(minibatch, 1, device=device)
    batch["state_value"] = batch["value_target"] + 0.1 * torch.randn(minibatch, 1, device=device)
    return loss, batch


def time_method(
    name: str, num_tasks: int, minibatch: int, hidden: list[int], device: torch.device, iters: int, warmup: int,
    method_kwargs: dict[str, Any],
) -> tuple[float, float]:
    """Median and min wall time (ms) of one update."""
    loss, batch = make_setup(num_tasks, minibatch, hidden, device)
    module = make_gradient_method(name, loss, num_tasks, **method_kwargs.get(name, {}))
    params = [p for p in loss.parameters() if p.requires_grad]
    opt = torch.optim.Adam(params, lr=5e-4)

    def update() -> None:
        opt.zero_grad(set_to_none=True)
        compute_gradients(module, batch)
        torch.nn.utils.clip_grad_norm_(params, 1.0)
        opt.step()

    for _ in range(warmup):
        update()
    sync(device)
    times = []
    for _ in range(iters):
        t0 = time.perf_counter()
        update()
        sync(device)
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times), min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    parser.add_argument("--tasks", type=int, nargs="+", default=[10, 50])
    parser.add_argument("--minibatch", type=int, default=16384)
    parser.add_argument("--hidden", type=int, nargs="+", default=[256, 128, 64])
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--iters", type=int, default=20)
    parser.add_argument("--warmup", type=int, default=3)
    parser.add_argument("--solver-iters", type=int, default=20, help="CAGrad dual-solver iterations")
    parser.add_argument("--threads", type=int, default=None, help="torch CPU threads")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    device = torch.device(args.device)
    method_kwargs = {"cagrad": {"solver_iters": args.solver_iters}}

    print(
        f"device: {torch.cuda.get_device_name(device) if device.type == 'cuda' else platform.processor() or 'cpu'}"
        f" | torch {torch.__version__} | minibatch {args.minibatch} | MLP {args.hidden} | obs 39+K"
        f" | grad methods on the critic (params=critic) | times: median (min) ms per update, {args.iters} updates"
    )
    header = "| K | " + " | ".join(args.methods) + " |"
    print()
    print(header)
    print("|" + "---|" * (len(args.methods) + 1))
    for k in args.tasks:
        cells = []
        base = None
        for name in args.methods:
            med, best = time_method(
                name, k, args.minibatch, args.hidden, device, args.iters, args.warmup, method_kwargs
            )
            if name == "none":
                base = med
            ratio = f", x{med / base:.2f}" if base and name != "none" else ""
            cells.append(f"{med:.2f} ({best:.2f}{ratio})")
        print(f"| {k} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
