"""A run launched by ``torchrun --nproc_per_node N examples/train.py ...``: what each of the N processes (ranks)
builds, where it writes, and the settings that do not run that way (one clear error each).

Each rank simulates ``env.num_envs / N`` worlds (every task's share, split by the env as in one process) from its
own env seed, on its own device (``cuda:<LOCAL_RANK>``, or the CPU with the gloo backend), and takes
``loss.minibatch_size / N`` samples of every minibatch (MT-SAC: ``loss.batch_size / N`` of every replayed batch, from
its own replay buffer of ``loss.replay_buffer_size / N``); the networks start equal (rank 0's), the gradients and the
per-task statistics are reduced over the ranks (:mod:`mtbench.utils.distributed`). Rank 0 logs, prints and writes
its checkpoints to ``checkpoint.dir``; rank ``r`` writes its own (its env, rollout and generators) to
``checkpoint.dir/rank<r>``. ``resume=<checkpoint.dir>/<file>`` resumes every rank from its own file, with the
number of processes the run was started with. Parkour's automatic flat pre-training runs on all ranks too: rank 0
holds the stage's lock and decides (reuse or train), the others follow.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch
from omegaconf import DictConfig, OmegaConf, open_dict

from ..utils import distributed
from ..utils.distributed import DistributedContext

#: rank r's env seed is ``seed + RANK_SEED_STRIDE * r`` (rank 0: the single-process run's)
RANK_SEED_STRIDE = 1_000_003


def check_distributed(cfg: DictConfig, context: DistributedContext) -> None:
    """One ``ValueError`` naming the parameter when the run cannot be split over ``context.world_size`` processes."""
    n = context.world_size
    sizes = ["env.num_envs"] + (["loss.batch_size", "loss.replay_buffer_size"] if cfg.loss.name == "sac" else [])
    for key in sizes:  # (loss.minibatch_size of the on-policy losses: checked by the Trainer against the batch)
        value = int(OmegaConf.select(cfg, key))
        if value % n:
            raise ValueError(f"{key}={value} must be divisible by the number of torchrun processes ({n})")
    if cfg.get("cudagraph_update") is True:
        raise ValueError("cudagraph_update=true does not run under torchrun (the gradient all-reduce is not captured); "
                         "use auto or false")
    device = str(cfg.get("device", "auto"))
    if device.startswith("cuda:"):
        raise ValueError(f"device={device}: under torchrun each process takes cuda:<LOCAL_RANK>; use device=cuda, "
                         "auto or cpu")


def join_run(cfg: DictConfig, device: torch.device) -> torch.device:
    """Under torchrun: check that ``cfg`` splits (:func:`check_distributed`), join the process group (once per process)
    and return this rank's device; ``device`` unchanged in a single process."""
    context = distributed.context_from_environment()
    if context is None:
        return device
    check_distributed(cfg, context)
    device = rank_device(device, context)
    distributed.init_process_group(context, device)
    return device


def rank_device(device: torch.device, context: DistributedContext) -> torch.device:
    """This rank's device: ``cuda:<local_rank>`` for a CUDA run, the CPU otherwise."""
    if device.type != "cuda":
        return device
    if context.local_rank >= torch.cuda.device_count():
        raise ValueError(f"LOCAL_RANK={context.local_rank} but this host has {torch.cuda.device_count()} GPUs: "
                         "use --nproc_per_node <= the number of GPUs")
    torch.cuda.set_device(context.local_rank)
    return torch.device("cuda", context.local_rank)


def rank_file(path: str | Path, rank: int) -> Path:
    """Rank ``rank``'s copy of the checkpoint ``path`` of rank 0 (``<dir>/rank<r>/<name>``; ``path`` for rank 0)."""
    path = Path(path)
    return path if rank == 0 else path.parent / f"rank{rank}" / path.name


def share_run_paths(cfg: DictConfig) -> None:
    """Every rank takes rank 0's ``logging.exp_name``, ``logging.log_dir`` and ``checkpoint.dir`` (the processes'
    clocks and Hydra directories may differ); rank ``r > 0`` checkpoints into ``checkpoint.dir/rank<r>``."""
    if not distributed.is_active():
        return
    exp_name, log_dir, checkpoint_dir = distributed.broadcast_object(
        (str(cfg.logging.exp_name), str(cfg.logging.log_dir), str(cfg.checkpoint.dir)))
    r = distributed.rank()
    with open_dict(cfg):
        cfg.logging.exp_name, cfg.logging.log_dir = exp_name, log_dir
        cfg.checkpoint.dir = str(Path(checkpoint_dir) / f"rank{r}") if r else checkpoint_dir


def rank_env_config(env_cfg: Any) -> Any:
    """The env config of this rank: ``num_envs`` divided by the number of processes (the config itself for one)."""
    n = distributed.world_size()
    if n == 1:
        return env_cfg
    plain = OmegaConf.to_container(env_cfg, resolve=True) if OmegaConf.is_config(env_cfg) else dict(env_cfg)
    plain["num_envs"] = int(plain["num_envs"]) // n
    return plain


def rank_seed(seed: int) -> int:
    """This rank's env seed (rank 0: ``seed``)."""
    return int(seed) + RANK_SEED_STRIDE * distributed.rank()


__all__ = ["RANK_SEED_STRIDE", "check_distributed", "join_run", "rank_device", "rank_env_config",
           "rank_file", "rank_seed", "share_run_paths"]
