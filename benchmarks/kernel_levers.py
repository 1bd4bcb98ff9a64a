"""Micro-benchmarks of two update levers (issue #15), former vs current implementation, forward + backward:

* per-task table rows: ``table[task_id]`` (autograd's indexed-scatter backward) vs
  :func:`mtbench.modules.task_rows.task_rows` (one-hot matmul backward), tables ``[10, C]``;
* MOORE's Gram-Schmidt and task mixing on ``[E, B, D]`` expert outputs: the vector recursion then
  ``einsum(w, U)`` vs the Gram-matrix coefficients ``C`` and ``einsum(w^T C, H)`` (as in ``MOORE.forward``).

    python benchmarks/kernel_levers.py                 # cuda, B = 16384, E = 4, D = 400
    python benchmarks/kernel_levers.py --device cpu --batch 2048

Median of ``--repeats`` timed calls after 3 warm-up calls, each closed by a device synchronisation.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Callable

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mtbench.modules.gram_schmidt import gram_schmidt_coefficients, gram_schmidt_vectors  # noqa: E402
from mtbench.modules.task_rows import task_rows  # noqa: E402


def _median_ms(fn: Callable[[], object], device: torch.device, repeats: int) -> float:
    for _ in range(3):
        fn()
    times = []
    for _ in range(repeats):
        if device.type == "cuda":
            torch.cuda.synchronize(device)
        t0 = time.perf_counter()
        fn()
        if device.type == "cuda":
            torch.cuda.synchronize(device)
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    p.add_argument("--batch", type=int, default=16384)
    p.add_argument("--tasks", type=int, default=10)
    p.add_argument("--experts", type=int, default=4)
    p.add_argument("--dim", type=int, default=400)
    p.add_argument("--repeats", type=int, default=20)
    args = p.parse_args(argv)
    dev = torch.device(args.device)
    gen = torch.Generator(device=dev).manual_seed(0)
    tid = torch.randint(0, args.tasks, (args.batch,), device=dev, generator=gen)
    print(f"device {torch.cuda.get_device_name(dev) if dev.type == 'cuda' else 'cpu'}, batch {args.batch}, "
          f"tasks {args.tasks}, matmul_precision {torch.get_float32_matmul_precision()}; ms, median of {args.repeats}")
    for cols in (4, 50, 256):
        table = torch.randn(args.tasks, cols, device=dev, requires_grad=True)
        grad = torch.randn(args.batch, cols, device=dev)

        def indexed(table: torch.Tensor = table, grad: torch.Tensor = grad) -> object:
            return torch.autograd.grad(table[tid], table, grad)

        def rows(table: torch.Tensor = table, grad: torch.Tensor = grad) -> object:
            return torch.autograd.grad(task_rows(table, tid), table, grad)

        print(f"task rows [{args.tasks}, {cols}]: table[task_id] {_median_ms(indexed, dev, args.repeats):.3f}, "
              f"task_rows {_median_ms(rows, dev, args.repeats):.3f}")
    h = torch.randn(args.experts, args.batch, args.dim, device=dev, requires_grad=True)
    w = torch.randn(args.batch, args.experts, device=dev, requires_grad=True)
    gv = torch.randn(args.batch, args.dim, device=dev)

    def former() -> object:
        return torch.autograd.grad(torch.einsum("be,ebd->bd", w, gram_schmidt_vectors(h)), (h, w), gv)

    def current() -> object:
        coef = torch.einsum("be,bej->bj", w.to(torch.float64), gram_schmidt_coefficients(h))
        return torch.autograd.grad(torch.einsum("be,ebd->bd", coef.to(h.dtype), h), (h, w), gv)

    print(f"Gram-Schmidt + mixing [{args.experts}, {args.batch}, {args.dim}]: vector recursion "
          f"{_median_ms(former, dev, args.repeats):.3f}, Gram matrix {_median_ms(current, dev, args.repeats):.3f}")


if __name__ == "__main__":
    main()
