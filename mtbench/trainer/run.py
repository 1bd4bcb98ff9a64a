"""Glue behind ``examples/train.py``: CPU defaults, logger construction, run + final per-task table."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any, Sequence

import torch
from omegaconf import DictConfig, open_dict

from .checkpoint import load_checkpoint
from .trainer import Trainer, resolve_device

LOGGERS = ("mcap", "none")
CPU_ENV_PRESET = "cpu_small"


def cpu_default_overrides(argv: Sequence[str], cuda_available: bool | None = None) -> list[str]:
    """Extra Hydra overrides for a CPU run: without an explicit ``env=...`` and when the run will be on the CPU
    (``device=cpu``, or ``auto`` without CUDA), train the small real configuration ``env=cpu_small``."""
    if cuda_available is None:
        cuda_available = torch.cuda.is_available()
    args = [a for a in argv if not a.startswith("-")]
    if any(a.split("=", 1)[0].lstrip("+~") == "env" for a in args if "=" in a):
        return []
    device = next((a.split("=", 1)[1] for a in args if a.split("=", 1)[0].lstrip("+~") == "device"), "auto")
    on_cpu = device == "cpu" or (device == "auto" and not cuda_available)
    return [f"env={CPU_ENV_PRESET}"] if on_cpu else []


def _choice(group: str, default: str) -> str:
    try:
        from hydra.core.hydra_config import HydraConfig

        if HydraConfig.initialized():
            return str(HydraConfig.get().runtime.choices.get(group, default))
    except ImportError:  # pragma: no cover
        pass
    return default


def experiment_name(cfg: DictConfig) -> str:
    """``<loss>-<arch>-<grad>-<env preset>-s<seed>-<YYYYmmdd-HHMMSS>`` unless ``logging.exp_name`` is set; a
    resumed run reuses the name stored in its checkpoint."""
    if cfg.logging.get("exp_name"):
        return str(cfg.logging.exp_name)
    if cfg.get("resume"):
        saved = load_checkpoint(cfg.resume)["config"]
        name = (saved.get("logging") or {}).get("exp_name")
        if name:
            return str(name)
    env = _choice("env", str(cfg.env.name))
    return f"{cfg.loss.name}-{cfg.arch.name}-{cfg.grad.name}-{env}-s{cfg.seed}-{time.strftime('%Y%m%d-%H%M%S')}"


def make_logger(cfg: DictConfig) -> Any:
    """``mtbench.logging.MCAPLogger`` (``logging.logger=mcap``, appends a segment when resuming) or ``None``."""
    kind = str(cfg.logging.get("logger", "mcap"))
    if kind not in LOGGERS:
        raise ValueError(f"unknown logging.logger {kind!r}; valid choices: {list(LOGGERS)}")
    if kind == "none":
        return None
    from ..logging import MCAPLogger

    return MCAPLogger(
        str(cfg.logging.exp_name),
        str(cfg.logging.log_dir),
        if_exists="append" if cfg.get("resume") else "error",
    )


def _close_logger(logger: Any) -> None:
    if logger is None:
        return
    close = getattr(logger, "close", None) or getattr(getattr(logger, "experiment", None), "close", None)
    if callable(close):
        close()


def run(cfg: DictConfig, env: Any = None) -> Trainer:
    """Build the trainer from ``cfg``, train, print the per-task success table, return the trainer."""
    with open_dict(cfg):
        cfg.logging.exp_name = experiment_name(cfg)
    if cfg.get("torch_threads"):
        torch.set_num_threads(int(cfg.torch_threads))
    trainer = Trainer(cfg, env=env)
    logger = make_logger(cfg)  # after the env is built: a failing build leaves no empty log file behind
    trainer.set_logger(logger)
    device = resolve_device(cfg.get("device"))
    print(
        f"mtbench | {cfg.loss.name} arch={cfg.arch.name} grad={cfg.grad.name} env={cfg.env.name} "
        f"tasks={trainer.num_tasks} envs={trainer.num_envs} horizon={trainer.horizon} device={device} | "
        f"{trainer.total_iterations} iterations x {trainer.frames_per_batch:,} frames "
        f"({trainer.epochs} epochs x {trainer.num_minibatches} minibatches of {trainer.minibatch_size:,}) | "
        f"run {cfg.logging.exp_name}",
        flush=True,
    )
    if trainer.iteration:
        print(f"resumed from {cfg.resume} at iteration {trainer.iteration} ({trainer.frames:,} frames)", flush=True)
    try:
        trainer.train()
    finally:
        trainer.close()
        _close_logger(logger)
    print(f"\nPer-task success over the last {trainer.window.window} iterations "
          f"({trainer.frames:,} frames, {trainer.skipped_updates} skipped updates):")
    print(trainer.success_table(), flush=True)
    final = Path(trainer.checkpoint_dir) / "final.pt"
    if trainer.checkpoint_final and trainer.iteration >= trainer.total_iterations and final.exists():
        print(f"checkpoint: {final}")
    return trainer


def main_argv() -> list[str]:
    """``sys.argv`` plus :func:`cpu_default_overrides` (called by ``examples/train.py`` before Hydra parses)."""
    return [*sys.argv, *cpu_default_overrides(sys.argv[1:])]


__all__ = ["CPU_ENV_PRESET", "LOGGERS", "cpu_default_overrides", "experiment_name", "main_argv", "make_logger", "run"]
