"""End-to-end MT-PPO / MT-GRPO / MT-PQN throughput: collection fps, update time and total frames/s.

    python benchmarks/train_throughput.py --env mt10_rand --num-envs 24576 --device cuda --iters 10
    python benchmarks/train_throughput.py --env mt10_rand --num-envs 24576 --device cuda --iters 10 --compile --cudagraphs
    python benchmarks/train_throughput.py --env mt10_rand --num-envs 24576 --arch moore --matmul-precision high
    python benchmarks/train_throughput.py --env mt10_rand --num-envs 8192 --device cuda --loss pqn --arch residual_mlp
    python benchmarks/train_throughput.py --env reach --num-envs 64 --device cpu --iters 3 --minibatch-size 1024
    python benchmarks/train_throughput.py --env mt10_rand --num-envs 4096 --loss sac --arch mlp_sac \
        --cudagraph-update true --replay-iterations 16 --iters 20   # MT-SAC, graphed once the buffer is full

``--loss sac`` times whole ``train_iteration()`` calls (their own collection / update timings, each closed by a host
read) after filling the replay buffer untimed (``--replay-iterations`` x ``num_envs`` transitions, so that the
CUDA-graphed update -- which starts once the buffer is full -- is what is timed) and ``--warmup`` more iterations.

The run uses the real training stack (conf/ + ``mtbench.trainer.build_trainer``: the trainer's rollout over the
native-autoreset env, the loss's value estimator, the loss preset's epochs of minibatch updates; ``--loss pqn --env
mt10_rand`` takes conf/loss/sizing/mt10_rand_pqn.yaml: 16 steps, 8 epochs of minibatches of 32768; give
``--num-envs 8192`` for the paper's 4 minibatches an epoch). The
first ``--warmup`` iterations (env graph capture, compilation, the update's graph capture) are not timed. Every phase
is closed with a device synchronisation so its time is real. The hooks' ``on_iteration_start`` is not called (PQN:
epsilon stays at its start value 1: uniformly random actions; the timed work is the same).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import torch
from hydra import compose, initialize_config_dir

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mtbench.trainer import build_trainer, resolve_device  # noqa: E402
from _timing import sync  # noqa: E402


def _off_policy(trainer, args: argparse.Namespace, device: torch.device, setup_s: float) -> None:
    """MT-SAC: fill the buffer, ``--warmup`` iterations, then ``--iters`` timed ``train_iteration()`` calls."""
    print(f"setup {setup_s:.1f}s | sac env={args.env} envs={trainer.num_envs} tasks={trainer.num_tasks} "
          f"{trainer.update_summary()} device={device} matmul_precision={torch.get_float32_matmul_precision()} "
          f"graphed_update={trainer.updater.graph}", flush=True)
    fill = 0
    while not trainer.replay_full() or trainer.iteration < trainer.warmup_iterations:
        trainer.train_iteration()
        fill += 1
    collect_s, update_s = [], []
    for i in range(args.warmup + args.iters):
        m = trainer.train_iteration()
        tag = "warmup" if i < args.warmup else "timed "
        print(f"{tag} iter {i + 1}: collect {m['time/collect_s']:.4f}s update {m['time/update_s']:.4f}s total "
              f"{m['fps']:,.0f} fps captured={trainer.updater._drawn_stage.captured}", flush=True)
        if i >= args.warmup:
            collect_s.append(m["time/collect_s"])
            update_s.append(m["time/update_s"])
    trainer.env.close()
    if not collect_s:
        return
    c, u = statistics.median(collect_s), statistics.median(update_s)
    n = trainer.frames_per_batch
    print(f"\nmedian over {len(collect_s)} iterations (after {fill} filling the buffer): collection {n / c:,.0f} "
          f"frames/s ({c * 1e3:.1f} ms/iter) | update {u * 1e3:.1f} ms/iter ({u / trainer.gradient_steps * 1e3:.2f} "
          f"ms/gradient step) | total {n / (c + u):,.0f} frames/s")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="mt10_rand", help="env name for mtbench.envs.make_env (or comma-separated tasks)")
    p.add_argument("--num-envs", type=int, default=24576)
    p.add_argument("--device", default="auto")
    p.add_argument("--iters", type=int, default=5, help="timed iterations")
    p.add_argument("--warmup", type=int, default=2, help="untimed iterations first")
    p.add_argument("--loss", default="ppo", choices=["ppo", "grpo", "pqn", "sac"])
    p.add_argument("--replay-iterations", type=int, default=16,
                   help="--loss sac: replay buffer of this many iterations x num_envs transitions (filled untimed)")
    p.add_argument("--arch", default="mlp", help="conf/arch preset")
    p.add_argument("--grad", default="none", help="conf/grad preset")
    p.add_argument("--horizon", type=int, default=None, help="override loss.horizon")
    p.add_argument("--epochs", type=int, default=None, help="override loss.epochs")
    p.add_argument("--minibatch-size", type=int, default=None, help="override loss.minibatch_size")
    p.add_argument("--compile", action="store_true", help="torch.compile the actor/critic networks")
    p.add_argument("--cudagraphs", action="store_true", help="CUDA-graph the collection policy")
    p.add_argument("--matmul-precision", default=None, choices=["highest", "high", "medium"],
                   help="override matmul_precision (torch.set_float32_matmul_precision; high = TF32 on CUDA)")
    p.add_argument("--cudagraph-update", default=None, choices=["auto", "true", "false"],
                   help="override cudagraph_update (the CUDA-graphed minibatch update)")
    p.add_argument("--threads", type=int, default=None, help="torch.set_num_threads")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--override", action="append", default=[], help="extra Hydra override (repeatable)")
    args = p.parse_args(argv)
    if args.threads:
        torch.set_num_threads(args.threads)
    device = resolve_device(args.device)

    env_name = f"[{args.env}]" if "," in args.env else args.env
    overrides = [
        f"env.name={env_name}",
        f"env.num_envs={args.num_envs}",
        f"loss={args.loss}",
        f"arch={args.arch}",
        f"grad={args.grad}",
        f"device={device}",
        f"seed={args.seed}",
        f"max_iterations={args.warmup + args.iters}",
        f"compile={str(args.compile).lower()}",
        f"cudagraphs={str(args.cudagraphs).lower()}",
        "logging.logger=none",
        "logging.progress=none",
        "checkpoint.every=0",
        "checkpoint.save_final=false",
        f"checkpoint.dir={tempfile.mkdtemp(prefix='mtbench-bench-')}",
    ]
    if args.matmul_precision is not None:
        overrides.append(f"matmul_precision={args.matmul_precision}")
    if args.cudagraph_update is not None:
        overrides.append(f"cudagraph_update={args.cudagraph_update}")
    if args.horizon is not None:
        overrides.append(f"loss.horizon={args.horizon}")
    if args.epochs is not None:
        overrides.append(f"loss.epochs={args.epochs}")
    if args.minibatch_size is not None:
        overrides.append(f"loss.minibatch_size={args.minibatch_size}")
    if args.loss == "sac":
        overrides = [o for o in overrides if not o.startswith("max_iterations=")]
        overrides += [f"loss.replay_buffer_size={args.replay_iterations * args.num_envs}",
                      f"max_iterations={args.replay_iterations + args.warmup + args.iters + 8}"]
    overrides += args.override
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose("config", overrides=overrides)

    t = time.perf_counter()
    trainer = build_trainer(cfg)
    sync(device)
    if args.loss == "sac":
        _off_policy(trainer, args, device, time.perf_counter() - t)
        return
    print(
        f"setup {time.perf_counter() - t:.1f}s | {args.loss} env={args.env} envs={trainer.num_envs} tasks={trainer.num_tasks} "
        f"horizon={trainer.horizon} batch={trainer.frames_per_batch:,} epochs={trainer.epochs} "
        f"minibatches={trainer.num_minibatches}x{trainer.minibatch_size:,} device={device} "
        f"compile={args.compile} cudagraphs={args.cudagraphs} torch_threads={torch.get_num_threads()} "
        f"matmul_precision={torch.get_float32_matmul_precision()} graphed_update={trainer.updater.graph}",
        flush=True,
    )
    collect_s, update_s = [], []
    for i in range(args.warmup + args.iters):
        sync(device)
        t0 = time.perf_counter()
        data, stats = trainer.collect()
        sync(device)
        t1 = time.perf_counter()
        means = trainer.update(trainer.advantage(data))
        skipped = float(means["skipped"]) * trainer.updates_per_iteration  # host read = sync
        sync(device)
        t2 = time.perf_counter()
        tag = "warmup" if i < args.warmup else "timed "
        print(
            f"{tag} iter {i + 1}: collect {t1 - t0:.3f}s ({trainer.frames_per_batch / (t1 - t0):,.0f} fps) "
            f"update {t2 - t1:.3f}s total {trainer.frames_per_batch / (t2 - t0):,.0f} fps skipped={skipped:.0f}",
            flush=True,
        )
        if i >= args.warmup:
            collect_s.append(t1 - t0)
            update_s.append(t2 - t1)
    trainer.env.close()
    if not collect_s:
        return
    c, u = statistics.median(collect_s), statistics.median(update_s)
    n = trainer.frames_per_batch
    print(
        f"\nmedian over {len(collect_s)} iterations: collection {n / c:,.0f} frames/s ({c * 1e3:.1f} ms/iter, "
        f"{c / trainer.horizon * 1e3:.2f} ms/step) | update {u:.3f} s/iter "
        f"({u / (trainer.epochs * trainer.num_minibatches) * 1e3:.1f} ms/minibatch) | total {n / (c + u):,.0f} frames/s"
    )


if __name__ == "__main__":
    main()
