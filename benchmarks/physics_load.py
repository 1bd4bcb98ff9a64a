"""How the physics load grows while MT-PPO learns: per iteration, collection and update time, contacts per world,
Newton iterations, and the time of one env step replaying the policy's last actions (synchronised).

A random policy barely touches the objects; a learning one grasps, pushes and presses them, and the contact
count (hence collision and solver work) rises. Use it to see which part of a training iteration is physics.

    python benchmarks/physics_load.py --num-envs 24576 --iters 20
    python benchmarks/physics_load.py --iters 16 --per-block   # then each task block's physics step alone
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import torch
import warp as wp
from hydra import compose, initialize_config_dir

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mtbench.sim import launch_all  # noqa: E402
from mtbench.trainer import build_trainer  # noqa: E402


def _timed_ms(fn, repeats: int = 5) -> float:
    torch.cuda.synchronize()
    t0 = time.perf_counter()
    for _ in range(repeats):
        fn()
    torch.cuda.synchronize()
    return 1e3 * (time.perf_counter() - t0) / repeats


def _block_load(state) -> tuple[float, torch.Tensor]:
    """A task block's contacts per world and its worlds' Newton iteration counts of the last physics step."""
    sim = state.sim
    return int(wp.to_torch(sim.data.nacon)[0]) / state.n, wp.to_torch(sim.data.solver_niter).float()


def per_block_report(env) -> None:
    """Physics step (substeps + kinematics) of all blocks on their own streams, on one stream, and of each block
    alone, from the current state (the mocap targets stay where the policy left them)."""
    sims = env._sims
    par = _timed_ms(lambda: launch_all(sims, "step", parallel_streams=True))
    ser = _timed_ms(lambda: launch_all(sims, "step", parallel_streams=False))
    print(f"physics step of all blocks: {par:.1f} ms on block streams, {ser:.1f} ms on one stream")
    for task, s in env.blocks:
        ms = _timed_ms(lambda: s.sim.launch("step"))
        contacts, niter = _block_load(s)
        print(f"  {task.name:22s} {ms:6.2f} ms | contacts/world {contacts:5.2f} "
              f"| Newton iterations mean {float(niter.mean()):.2f} max {float(niter.max()):.0f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="mt10_rand")
    p.add_argument("--num-envs", type=int, default=24576)
    p.add_argument("--iters", type=int, default=20)
    p.add_argument("--every", type=int, default=3, help="report every N iterations")
    p.add_argument("--per-block", action="store_true", help="after the last iteration, time each task block")
    args = p.parse_args()
    if not torch.cuda.is_available():
        raise SystemExit("physics_load.py measures GPU timings; no CUDA device found")
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose("config", overrides=[
            f"env.name={args.env}", f"env.num_envs={args.num_envs}", "logging.logger=none", "logging.progress=none",
            "checkpoint.every=0", "checkpoint.save_final=false", f"checkpoint.dir={tempfile.mkdtemp()}"])
    trainer = build_trainer(cfg)
    env = trainer.base_env
    print(f"device: {torch.cuda.get_device_name()}; date {time.strftime('%Y-%m-%d')}; {args.env} x {args.num_envs}")
    for i in range(args.iters):
        torch.cuda.synchronize()
        t0 = time.perf_counter()
        data, _ = trainer.collect()
        torch.cuda.synchronize()
        t1 = time.perf_counter()
        trainer.update(trainer.advantage(data))
        torch.cuda.synchronize()
        t2 = time.perf_counter()
        if i % args.every and i != args.iters - 1:
            continue
        loads = [_block_load(s) for _, s in env.blocks]
        ncon = sum(c for c, _ in loads) / len(loads)
        niter = sum(float(n.mean()) for _, n in loads) / len(loads)
        action = data["action"][:, -1].clone()
        step_ms = _timed_ms(lambda: env._core_step(action), repeats=10)
        print(f"iter {i + 1}: collect {t1 - t0:.3f}s update {t2 - t1:.3f}s | contacts/world {ncon:.2f} | "
              f"Newton iterations {niter:.2f} | env step {step_ms:.1f} ms", flush=True)
    if args.per_block:
        per_block_report(env)
    trainer.env.close()


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    main()
