"""Where the minibatch update's time goes: torch.profiler of eager MT-PPO minibatch updates of one architecture /
gradient method on the real training stack (MT10-rand by default), the top operators and kernels by GPU time.

    python benchmarks/update_profile.py --arch moore                  # cuda, TF32 (matmul_precision=high)
    python benchmarks/update_profile.py --grad pcgrad --matmul-precision highest
    python benchmarks/update_profile.py --device cpu --num-envs 64 --minibatch-size 512   # plumbing only

One rollout is collected and its advantages computed (``build_trainer``, the config's sizes); then 5 eager updates
warm up, 10 are timed (``ms/minibatch``, host-synchronised) and ``--profile-steps`` are profiled. The eager update
pays one kernel launch per operator; the graphed update of training replays the same kernels, so the profile's
GPU time per minibatch is what a graphed update costs when it is not launch-bound.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import torch
from hydra import compose, initialize_config_dir
from torch.profiler import ProfilerActivity, profile

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mtbench.trainer import build_trainer, resolve_device  # noqa: E402
from _timing import sync  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="mt10_rand")
    p.add_argument("--num-envs", type=int, default=24576)
    p.add_argument("--arch", default="mlp", help="conf/arch preset")
    p.add_argument("--grad", default="none", help="conf/grad preset")
    p.add_argument("--minibatch-size", type=int, default=None, help="override loss.minibatch_size")
    p.add_argument("--matmul-precision", default="high", choices=["highest", "high", "medium"])
    p.add_argument("--device", default="cuda")
    p.add_argument("--profile-steps", type=int, default=5)
    p.add_argument("--rows", type=int, default=30, help="rows of the profiler table")
    args = p.parse_args()
    device = resolve_device(args.device)
    overrides = [
        f"env.name={args.env}", f"env.num_envs={args.num_envs}", "loss=ppo", f"arch={args.arch}", f"grad={args.grad}",
        f"device={device}", "seed=0", "max_iterations=1", f"matmul_precision={args.matmul_precision}",
        "cudagraph_update=false", "grad.diagnostics_every=0", "logging.logger=none", "logging.progress=none",
        "checkpoint.every=0", "checkpoint.save_final=false",
        f"checkpoint.dir={tempfile.mkdtemp(prefix='mtbench-profile-')}",
    ]
    if args.minibatch_size is not None:
        overrides.append(f"loss.minibatch_size={args.minibatch_size}")
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    trainer = build_trainer(cfg)
    data, _ = trainer.collect()
    flat = trainer.advantage(data).exclude("next").reshape(-1)
    mb = trainer.minibatch_size
    n = flat.batch_size[0] // mb
    if n < 1:
        raise ValueError(f"--minibatch-size {mb} exceeds the batch of {flat.batch_size[0]} frames")
    step = trainer.updater.step
    for i in range(5):
        step(flat[(i % n) * mb:(i % n + 1) * mb])
    sync(device)
    t = time.perf_counter()
    for i in range(10):
        step(flat[(i % n) * mb:(i % n + 1) * mb])
    sync(device)
    print(f"arch={args.arch} grad={args.grad} matmul_precision={args.matmul_precision} device={device}: eager update "
          f"{(time.perf_counter() - t) / 10 * 1e3:.2f} ms/minibatch of {mb}", flush=True)
    activities = [ProfilerActivity.CPU] + ([ProfilerActivity.CUDA] if device.type == "cuda" else [])
    with profile(activities=activities) as prof:
        for i in range(args.profile_steps):
            step(flat[(i % n) * mb:(i % n + 1) * mb])
        sync(device)
    events = prof.key_averages()
    sort = "cuda_time_total" if device.type == "cuda" else "cpu_time_total"
    print(events.table(sort_by=sort, row_limit=args.rows, max_name_column_width=70))
    if device.type == "cuda":
        kernels = [e for e in events if e.device_type == torch.autograd.DeviceType.CUDA]
        gpu_ms = sum(e.self_device_time_total for e in kernels) / args.profile_steps / 1e3
        f64 = sum(e.self_device_time_total for e in kernels if "f64" in e.key or "d884" in e.key or "dgemm" in e.key)
        print(f"GPU kernel time {gpu_ms:.2f} ms/minibatch; float64 GEMMs {f64 / args.profile_steps / 1e3:.2f} ms; "
              f"{sum(e.count for e in kernels) / args.profile_steps:.0f} kernels/minibatch")
    trainer.env.close()


if __name__ == "__main__":
    main()
