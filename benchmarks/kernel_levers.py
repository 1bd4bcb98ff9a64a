"""Micro-benchmarks of two update levers (issue #15), former vs current implementation, forward + backward:

* per-task table rows: ``table[task_id]`` (autograd's indexed-scatter backward) vs
  :func:`mtbench.modules.task_rows.task_rows` (one-hot matmul backward), tables ``[10, C]``;
* MOORE's Gram-Schmidt and task mixing on ``[E, B, D]`` expert outputs: the vector recursion then
  ``einsum(w, U)`` vs the Gram-matrix coefficients ``C`` and ``einsum(w^T C, H)`` (as in ``MOORE.forward``), and
  two candidate ways to the float64 Gram matrix: the ``E (E + 1) / 2`` pairwise products summed element-wise
  (no batched GEMM with 4 x 4 outputs) and ``torch.compile`` of the current form (``--compile``, CUDA).

    python benchmarks/kernel_levers.py                 # cuda, B = 16384, E = 4, D = 400
    python benchmarks/kernel_levers.py --device cpu --batch 2048

Median of ``--repeats`` timed calls after 3 warm-up calls, each closed by a device synchronisation.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mtbench.modules.gram_schmidt import (  # noqa: E402
    coefficients_from_gram,
    gram_schmidt_coefficients,
    gram_schmidt_vectors,
)
from mtbench.modules.task_rows import task_rows  # noqa: E402
from _timing import median_ms  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    p.add_argument("--batch", type=int, default=16384)
    p.add_argument("--tasks", type=int, default=10)
    p.add_argument("--experts", type=int, default=4)
    p.add_argument("--dim", type=int, default=400)
    p.add_argument("--repeats", type=int, default=20)
    p.add_argument("--compile", action="store_true", help="also time torch.compile of the current Gram-Schmidt")
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

        print(f"task rows [{args.tasks}, {cols}]: table[task_id] {median_ms(indexed, dev, args.repeats, warmup=3):.3f}, "
              f"task_rows {median_ms(rows, dev, args.repeats, warmup=3):.3f}")
    h = torch.randn(args.experts, args.batch, args.dim, device=dev, requires_grad=True)
    w = torch.randn(args.batch, args.experts, device=dev, requires_grad=True)
    gv = torch.randn(args.batch, args.dim, device=dev)

    def former() -> object:
        return torch.autograd.grad(torch.einsum("be,ebd->bd", w, gram_schmidt_vectors(h)), (h, w), gv)

    def current() -> object:
        coef = (w.to(torch.float64).unsqueeze(-1) * gram_schmidt_coefficients(h)).sum(1)  # as MOORE.forward
        return torch.autograd.grad(torch.einsum("be,ebd->bd", coef.to(h.dtype), h), (h, w), gv)

    iu = torch.triu_indices(args.experts, args.experts, device=dev)

    def pairwise_gram(h: torch.Tensor) -> torch.Tensor:
        h64 = h.to(torch.float64)
        prods = (h64[iu[0]] * h64[iu[1]]).sum(-1)  # [pairs, N]
        a = prods.new_zeros(args.experts, args.experts, prods.shape[1])
        a = a.index_put((iu[0], iu[1]), prods).index_put((iu[1], iu[0]), prods)
        return a.permute(2, 0, 1)  # [N, E, E]

    def pairwise() -> object:
        coef = (w.to(torch.float64).unsqueeze(-1) * coefficients_from_gram(pairwise_gram(h))).sum(1)
        return torch.autograd.grad(torch.einsum("be,ebd->bd", coef.to(h.dtype), h), (h, w), gv)

    ref = current()
    for got in (former(), pairwise()):  # the variants compute the same gradients
        for a, b in zip(ref, got, strict=True):
            torch.testing.assert_close(a, b, rtol=1e-3, atol=1e-4)
    line = (f"Gram-Schmidt + mixing [{args.experts}, {args.batch}, {args.dim}]: vector recursion "
            f"{median_ms(former, dev, args.repeats, warmup=3):.3f}, Gram matrix {median_ms(current, dev, args.repeats, warmup=3):.3f}, "
            f"pairwise Gram {median_ms(pairwise, dev, args.repeats, warmup=3):.3f}")
    if args.compile:
        compiled = torch.compile(current)
        line += f", compiled Gram matrix {median_ms(compiled, dev, args.repeats, warmup=3):.3f}"
    print(line)


if __name__ == "__main__":
    main()
