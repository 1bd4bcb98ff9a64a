"""Several processes training one run (``torchrun``): the process group and the cross-rank reductions.

Each rank simulates its share of every task's worlds on its own device; after every backward pass the gradients
are averaged over the ranks (data parallelism, as DDP does, without wrapping the TensorDict modules); the per-task
statistics that the single-process run computes over its whole batch -- the observation and value normalisers'
running means, the per-task advantage standardisation, the episode statistics -- are computed over all ranks'
samples; one rank logs and prints. With equal shares this is the single-process run on the union of the ranks'
data (``tests/test_distributed.py`` compares one update of two processes with one update of one process).

The reductions here are no-ops until :func:`init_process_group` made this process a rank of a group of two or more
(a plain ``python`` run never pays for them, and a user's own process group is not touched): the library's
numerics call :func:`all_reduce_sum_` unconditionally and stay single-process code.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import torch
import torch.distributed as dist
from torch import nn

_ACTIVE = False
#: keys of the episode statistics that are maxima, not sums (``EpisodeStatsWindow``: the highest terrain level)
MAX_STAT_KEYS = ("max_terrain_level",)


@dataclass(frozen=True)
class DistributedContext:
    """Where this process sits in a ``torchrun`` launch: ``rank`` of ``world_size``, ``local_rank`` on its host."""

    rank: int
    world_size: int
    local_rank: int

    @property
    def is_main(self) -> bool:
        """Whether this is rank 0 (the one that logs, prints and writes the run's files)."""
        return self.rank == 0


def context_from_environment(environ: Mapping[str, str] | None = None) -> DistributedContext | None:
    """The launch that ``torchrun`` describes in ``WORLD_SIZE``, ``RANK`` and ``LOCAL_RANK``; ``None`` for a single
    process (no ``WORLD_SIZE``, or 1)."""
    env = os.environ if environ is None else environ
    world_size = int(env.get("WORLD_SIZE", "1") or 1)
    if world_size <= 1:
        return None
    try:
        rank = int(env["RANK"])
    except KeyError as err:
        raise ValueError("WORLD_SIZE > 1 but RANK is not set: launch with torchrun --nproc_per_node N") from err
    return DistributedContext(rank=rank, world_size=world_size, local_rank=int(env.get("LOCAL_RANK", rank)))


def init_process_group(context: DistributedContext, device: torch.device) -> None:
    """Join the group of ``context`` (``nccl`` on CUDA, ``gloo`` on the CPU; rendezvous from ``torchrun``'s
    ``MASTER_ADDR``/``MASTER_PORT``) and turn the reductions of this module on."""
    global _ACTIVE
    if not dist.is_initialized():
        backend = "nccl" if device.type == "cuda" else "gloo"
        kwargs = {"device_id": device} if device.type == "cuda" else {}
        dist.init_process_group(backend, rank=context.rank, world_size=context.world_size, **kwargs)
    if dist.get_world_size() != context.world_size or dist.get_rank() != context.rank:
        raise RuntimeError(f"the process group (rank {dist.get_rank()} of {dist.get_world_size()}) does not match "
                           f"torchrun's (rank {context.rank} of {context.world_size})")
    _ACTIVE = context.world_size > 1


def shutdown() -> None:
    """Leave the process group (if this module joined one) and turn the reductions off."""
    global _ACTIVE
    if _ACTIVE and dist.is_initialized():
        dist.destroy_process_group()
    _ACTIVE = False


def is_active() -> bool:
    """Whether the cross-rank reductions are on (this process is a rank of a group of two or more)."""
    return _ACTIVE


def world_size() -> int:
    """Number of ranks (1 without a group)."""
    return dist.get_world_size() if _ACTIVE else 1


def rank() -> int:
    """This process's rank (0 without a group)."""
    return dist.get_rank() if _ACTIVE else 0


def all_reduce_sum_(tensor: torch.Tensor) -> torch.Tensor:
    """Sum ``tensor`` over the ranks, in place (a no-op without a group); returns it."""
    if _ACTIVE:
        dist.all_reduce(tensor, op=dist.ReduceOp.SUM)
    return tensor


def all_reduce_mean_(tensors: Sequence[torch.Tensor]) -> None:
    """Average every tensor of ``tensors`` over the ranks, in place, in one collective (flattened into one buffer
    per dtype; a no-op without a group)."""
    if not _ACTIVE or not tensors:
        return
    by_dtype: dict[torch.dtype, list[torch.Tensor]] = {}
    for t in tensors:
        by_dtype.setdefault(t.dtype, []).append(t)
    n = dist.get_world_size()
    for group in by_dtype.values():
        flat = torch.cat([t.reshape(-1) for t in group])
        dist.all_reduce(flat, op=dist.ReduceOp.SUM)
        flat /= n
        offset = 0
        for t in group:
            t.copy_(flat[offset: offset + t.numel()].view_as(t))
            offset += t.numel()


def all_reduce_stats_(stats: Mapping[str, torch.Tensor]) -> None:
    """Per-task episode statistics of every rank combined, in place: sums summed, :data:`MAX_STAT_KEYS` maxed
    (a no-op without a group). Every rank must hold the same keys."""
    if not _ACTIVE:
        return
    for key in sorted(stats.keys()):
        op = dist.ReduceOp.MAX if key in MAX_STAT_KEYS else dist.ReduceOp.SUM
        dist.all_reduce(stats[key], op=op)


def broadcast_(tensors: Sequence[torch.Tensor], src: int = 0) -> None:
    """Overwrite ``tensors`` on every rank with rank ``src``'s (a no-op without a group)."""
    if not _ACTIVE:
        return
    for t in tensors:
        dist.broadcast(t, src=src)


def broadcast_module_(module: nn.Module, src: int = 0) -> None:
    """Overwrite every parameter and buffer of ``module`` with rank ``src``'s (a no-op without a group): the ranks
    start from the same networks."""
    with torch.no_grad():
        broadcast_([t.data for t in (*module.parameters(), *module.buffers())], src=src)


def broadcast_object(obj: Any, src: int = 0) -> Any:
    """Rank ``src``'s ``obj`` (picklable) on every rank (``obj`` itself without a group)."""
    if not _ACTIVE:
        return obj
    box = [obj]
    dist.broadcast_object_list(box, src=src)
    return box[0]


def barrier() -> None:
    """Wait until every rank got here (a no-op without a group)."""
    if _ACTIVE:
        dist.barrier()


def any_rank(flag: bool, device: torch.device) -> bool:
    """Whether ``flag`` holds on at least one rank (every rank gets the same answer; ``flag`` without a group)."""
    if not _ACTIVE:
        return bool(flag)
    value = torch.tensor([1.0 if flag else 0.0], device=device)
    dist.all_reduce(value, op=dist.ReduceOp.MAX)
    return bool(value.item() > 0)


__all__ = [
    "DistributedContext",
    "MAX_STAT_KEYS",
    "all_reduce_mean_",
    "all_reduce_stats_",
    "all_reduce_sum_",
    "any_rank",
    "barrier",
    "broadcast_",
    "broadcast_module_",
    "broadcast_object",
    "context_from_environment",
    "init_process_group",
    "is_active",
    "rank",
    "shutdown",
    "world_size",
]
