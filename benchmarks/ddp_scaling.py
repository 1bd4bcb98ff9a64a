"""Frames/s of one run split over 1, 2, 4, ... processes (``torchrun``; docs/training.md, "Several processes").

    python benchmarks/ddp_scaling.py --nproc 1 2 4 -- env=mt10_rand loss=ppo            # one host with 4 GPUs
    python benchmarks/ddp_scaling.py --nproc 1 2 4 -- env=mt50_rand loss=ppo arch=moore
    python benchmarks/ddp_scaling.py --nproc 1 2 --iters 12 -- device=cpu env=cpu_small   # a CPU check (gloo)
    python benchmarks/ddp_scaling.py --nproc 1 2 --weak -- env=mt10_rand env.num_envs=24576 loss.minibatch_size=16384

Each process count runs ``examples/train.py`` (``torchrun --nproc_per_node N`` for N > 1) for ``--iters`` iterations
with the given overrides, no logger and no checkpoint. By default the overrides are the run's totals
(``env.num_envs`` worlds in all, split over the processes: strong scaling); with ``--weak`` the given
``env.num_envs`` and ``loss.minibatch_size`` are each process's share and are multiplied by the process count (every
process keeps one process's work: weak scaling, how runs grow with more GPUs). The script reads the frames/s that
the trainer prints per iteration (all processes' frames; collection and update, the iteration's own timing). The
figure is the median over the second half of the iterations (the first half holds graph captures and compilation).
Printed: frames/s per process count and its ratio to one process.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FPS = re.compile(r"^\[iter\s+\d+/\d+\] frames=[\d,]+ fps=([\d,]+)", re.MULTILINE)


WEAK_KEYS = ("env.num_envs", "loss.minibatch_size")


def scale_overrides(overrides: list[str], nproc: int) -> list[str]:
    """``overrides`` with ``env.num_envs`` and ``loss.minibatch_size`` multiplied by ``nproc`` (``--weak``)."""
    values = {o.split("=", 1)[0]: o.split("=", 1)[1] for o in overrides if "=" in o}
    missing = [k for k in WEAK_KEYS if k not in values]
    if missing:
        raise SystemExit(f"--weak needs the per-process sizes among the overrides; missing: {missing} "
                         f"(e.g. env.num_envs=24576 loss.minibatch_size=16384)")
    scaled = []
    for o in overrides:
        key = o.split("=", 1)[0]
        scaled.append(f"{key}={int(values[key]) * nproc}" if key in WEAK_KEYS else o)
    return scaled


def run(nproc: int, iters: int, overrides: list[str], workdir: Path) -> list[float]:
    """The per-iteration frames/s of one run on ``nproc`` processes."""
    train = str(ROOT / "examples" / "train.py")
    launcher = [sys.executable, "-m", "torch.distributed.run", f"--nproc_per_node={nproc}", train] if nproc > 1 \
        else [sys.executable, train]
    cmd = [*launcher, *overrides, f"max_iterations={iters}", "logging.logger=none", "logging.progress=line",
           "logging.print_every=1", "checkpoint.every=0", "checkpoint.save_final=false",
           f"checkpoint.dir={workdir / f'ck{nproc}'}", f"hydra.run.dir={workdir / f'run{nproc}'}"]
    print("+", " ".join(cmd), flush=True)
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=workdir)
    if done.returncode != 0:
        raise SystemExit(f"{nproc} processes: exit {done.returncode}\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}")
    return [float(x.replace(",", "")) for x in FPS.findall(done.stdout)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nproc", type=int, nargs="+", default=[1, 2], help="process counts to run")
    parser.add_argument("--iters", type=int, default=30, help="iterations per run (the second half is timed)")
    parser.add_argument("--weak", action="store_true",
                        help="env.num_envs and loss.minibatch_size are per process (multiplied by the process count)")
    parser.add_argument("overrides", nargs="*", help="examples/train.py overrides (after --)")
    args = parser.parse_args()
    if any(n < 1 for n in args.nproc):
        parser.error(f"--nproc must be >= 1; got {args.nproc}")
    if args.iters < 2:
        parser.error(f"--iters must be >= 2; got {args.iters}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.nproc:
            overrides = scale_overrides(list(args.overrides), n) if args.weak else list(args.overrides)
            fps = run(n, args.iters, overrides, Path(tmp))
            timed = fps[len(fps) // 2:]
            if not timed:
                raise SystemExit(f"{n} processes: no per-iteration frames/s in the output")
            rows.append((n, statistics.median(timed)))
    base = dict(rows).get(1)
    print(f"\n{'processes':>9} {'frames/s':>12} {'x one process':>14}")
    for n, fps in rows:
        ratio = f"{fps / base:.2f}" if base else "n/a"
        print(f"{n:>9} {fps:>12,.0f} {ratio:>14}")


if __name__ == "__main__":
    main()
