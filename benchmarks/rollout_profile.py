"""Where a training rollout's time goes: the trainer's collection (policy + env step, ``Rollout.collect``) against
its parts run alone, and a torch.profiler table of one rollout.

    CUDA_DEVICE_MAX_CONNECTIONS=32 python benchmarks/rollout_profile.py --env mt50_rand --num-envs 24576
    python benchmarks/rollout_profile.py --env mt10_rand --num-envs 24576 --loss pqn --arch residual_mlp
    python benchmarks/rollout_profile.py --env parkour_easy --num-envs 4096 --warmup 60 --override pretrained=<ckpt>
    python benchmarks/rollout_profile.py --env mt10_rand --num-envs 20 --device cpu --threads 1   # plumbing only

Built on the real training stack (conf/ + ``build_trainer``, the env's default ``compile_stages``). ``--warmup``
rollouts (default 2) warm up (CUDA graph capture, compilation); more of them spread the worlds over their episodes
as in training (Parkour: a step costs more the further the robots are into their terrains; ``--override
pretrained=<checkpoint>`` profiles a trained policy). Then, in ms per env step (host-synchronised where named):

* ``rollout``: ``trainer.collect()`` (what training times as collection), synchronised once at its end;
* ``policy``: the policy module on the rollout's TensorDict, alone (synchronised before and after);
* ``env step``: ``env.step_and_maybe_reset`` (the transformed env: TorchRL's wrapper, the observation
  normaliser, the base env's step) on the policy's output, alone;
* ``base env step``: the base env's ``step_and_maybe_reset`` with a random action (what
  ``benchmarks/env_throughput.py`` times), alone;
* ``episode stats``: ``base_env.pop_episode_stats()`` (called once per rollout by training).

The parts run back to back with synchronisations, so a sum above ``rollout`` means they overlap in training; a
``rollout`` above the sum means the loop adds time between them. The profile of one more rollout prints the top
operators by self CPU time (host-side cost) and, on CUDA, by device time, and the GPU-busy time per step (sum of
kernel times): far below the wall time per step means the rollout is bound by the host.
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
from torch.profiler import ProfilerActivity, profile

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mtbench.trainer import build_trainer, resolve_device  # noqa: E402
from mtbench.trainer.rollout import base_env  # noqa: E402
from mtbench.trainer.run import parkour_arch_overrides  # noqa: E402
from _timing import median_ms, sync  # noqa: E402


# kernel name fragments -> kind (first match wins; MuJoCo Warp's kernels are named after their Python functions)
KERNEL_KINDS = (
    ("heightfield collision", ("hfield",)),
    ("collision", ("ccd", "collision", "broadphase", "narrowphase", "primitive", "box_box", "contact_params")),
    ("constraint solver", ("efc", "solve", "linesearch", "cholesky", "gradient", "constraint", "jaref", "limit_",
                           "equality", "mul_m")),
    ("torch", ("at::", "aten::", "elementwise", "reduce", "gemm", "cutlass", "triton", "memcpy", "memset", "Memcpy",
               "Memset")),
)


def kernel_shares(times: list[tuple[str, float]]) -> dict[str, float]:
    """Share of the summed kernel time per kind (:data:`KERNEL_KINDS`, the rest: "other physics"), largest first."""
    total = sum(t for _, t in times) or 1.0
    shares: dict[str, float] = {}
    for name, t in times:
        kind = next((k for k, frags in KERNEL_KINDS if any(f in name for f in frags)), "other physics")
        shares[kind] = shares.get(kind, 0.0) + t / total
    return dict(sorted(shares.items(), key=lambda kv: -kv[1]))


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="mt50_rand", help="env preset (conf/env) or task list for env.name")
    p.add_argument("--num-envs", type=int, default=24576)
    p.add_argument("--loss", default="ppo", choices=["ppo", "grpo", "pqn"])
    p.add_argument("--arch", default="mlp", help="conf/arch preset")
    p.add_argument("--device", default="auto")
    p.add_argument("--warmup", type=int, default=2,
                   help="rollouts before the timed ones (more: worlds spread over their episodes, as in training)")
    p.add_argument("--rollouts", type=int, default=3, help="timed rollouts")
    p.add_argument("--steps", type=int, default=20, help="timed repetitions of each part")
    p.add_argument("--rows", type=int, default=25, help="rows of each profiler table")
    p.add_argument("--threads", type=int, default=None, help="torch.set_num_threads")
    p.add_argument("--override", action="append", default=[], help="extra Hydra override (repeatable)")
    args = p.parse_args(argv)
    if args.num_envs < 1 or args.rollouts < 1 or args.steps < 1 or args.warmup < 1:
        p.error("--num-envs, --warmup, --rollouts and --steps must be >= 1")
    if args.threads is not None:
        torch.set_num_threads(args.threads)
    device = resolve_device(args.device)
    env_key = f"env={args.env}" if (ROOT / "conf" / "env" / f"{args.env}.yaml").is_file() else f"env.name={args.env}"
    overrides = [
        env_key, f"env.num_envs={args.num_envs}", f"loss={args.loss}", f"arch={args.arch}", f"device={device}",
        "seed=0", "max_iterations=1", "logging.logger=none", "logging.progress=none", "checkpoint.every=0",
        "checkpoint.save_final=false", f"checkpoint.dir={tempfile.mkdtemp(prefix='mtbench-rollout-profile-')}",
        *args.override,
    ]
    overrides, note = parkour_arch_overrides(overrides)  # the Go1 preset of the arch, as examples/train.py does
    if note:
        print(note)
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    t = time.perf_counter()
    trainer = build_trainer(cfg)
    for _ in range(args.warmup):
        trainer.collect()
    sync(device)
    horizon = trainer.horizon
    print(f"rollout profile | {args.env} envs={trainer.num_envs} loss={args.loss} arch={args.arch} horizon={horizon} "
          f"device={device} | setup + {args.warmup} warm-up rollouts {time.perf_counter() - t:.1f} s", flush=True)

    rollout_ms = []
    for _ in range(args.rollouts):
        sync(device)
        t = time.perf_counter()
        trainer.collect()
        sync(device)
        rollout_ms.append((time.perf_counter() - t) * 1e3 / horizon)
    policy = trainer.rollout.policy
    env, base = trainer.env, base_env(trainer.env)
    td = env.reset()
    policy_ms = median_ms(lambda: policy(td.clone(False)), device, args.steps)
    acted = policy(td.clone(False))

    def policy_and_env_step() -> None:
        nonlocal acted
        _, nxt = env.step_and_maybe_reset(acted)
        acted = policy(nxt)

    base_td = base.reset()

    def base_step() -> None:
        nonlocal base_td
        _, base_td = base.step_and_maybe_reset(base.rand_action(base_td))

    env_ms = median_ms(policy_and_env_step, device, args.steps) - policy_ms
    base_ms = median_ms(base_step, device, args.steps)
    stats_ms = median_ms(base.pop_episode_stats, device, max(3, args.steps // 4))
    rows = [("rollout (trainer.collect, per step)", statistics.median(rollout_ms)), ("policy", policy_ms),
            ("env step (transformed env)", env_ms), ("base env step (random action)", base_ms),
            ("episode stats (per rollout)", stats_ms)]
    for name, ms in rows:
        print(f"  {name:38s} {ms:9.2f} ms")
    print(f"  {'policy + env step, alone':38s} {policy_ms + env_ms:9.2f} ms | frames/s of the rollout: "
          f"{trainer.num_envs / statistics.median(rollout_ms) * 1e3:,.0f}", flush=True)

    activities = [ProfilerActivity.CPU] + ([ProfilerActivity.CUDA] if device.type == "cuda" else [])
    # the env and trainer may hold CUDA graphs: the profiler sees their replays as one op each
    with profile(activities=activities) as prof:
        t = time.perf_counter()
        trainer.collect()
        sync(device)
        wall_ms = (time.perf_counter() - t) * 1e3 / horizon
    events = prof.key_averages()
    print(events.table(sort_by="self_cpu_time_total", row_limit=args.rows, max_name_column_width=60))
    if device.type == "cuda":
        print(events.table(sort_by="self_cuda_time_total", row_limit=args.rows, max_name_column_width=60))
        kernels = [e for e in events if e.device_type == torch.autograd.DeviceType.CUDA]
        busy = sum(e.self_device_time_total for e in kernels) / horizon / 1e3
        launches = sum(e.count for e in kernels) / horizon
        print(f"profiled rollout: {wall_ms:.2f} ms/step wall, {busy:.2f} ms/step of kernel time (summed over "
              f"streams), {launches:.0f} kernels/step")
        shares = kernel_shares([(e.key, e.self_device_time_total) for e in kernels])
        print("kernel time by kind: " + ", ".join(f"{kind} {share:.1%}" for kind, share in shares.items()))
    cpu_ms = sum(e.self_cpu_time_total for e in events) / horizon / 1e3
    print(f"profiled rollout: host time in torch ops {cpu_ms:.2f} ms/step")
    trainer.env.close()


if __name__ == "__main__":
    main()
