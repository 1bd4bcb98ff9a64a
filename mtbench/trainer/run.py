"""Glue behind ``examples/train.py``: CPU defaults, the resumed run's directory, the MCAP logger, train, print the
per-task success table."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any, Sequence

import torch
from omegaconf import DictConfig, open_dict

from ..utils import distributed
from .builder import build_trainer
from .config import LOGGERS, as_config, check_config, resolve_device
from .hooks import Checkpointer, MetricsLogger, NonFiniteGuard
from .loop import TrainingLoop
from .pretraining import needs_flat_stage, pretrain_flat
from .ranks import join_run

CPU_ENV_PRESET = "cpu_small"
CONF_DIR = Path(__file__).resolve().parents[2] / "conf"


def _overrides(argv: Sequence[str]) -> dict[str, str]:
    """``key=value`` command-line overrides (``+``/``~`` prefixes dropped)."""
    args = [a for a in argv if not a.startswith("-") and "=" in a]
    return {a.split("=", 1)[0].lstrip("+~"): a.split("=", 1)[1] for a in args}


def _config_name(argv: Sequence[str]) -> str | None:
    """The ``--config-name``/``-cn`` given on the command line, if any."""
    for i, arg in enumerate(argv):
        if arg in ("--config-name", "-cn") and i + 1 < len(argv):
            return argv[i + 1]
        if arg.startswith("--config-name="):
            return arg.split("=", 1)[1]
    return None


def cpu_default_overrides(argv: Sequence[str], cuda_available: bool | None = None) -> list[str]:
    """Extra Hydra overrides for a CPU run: without an explicit ``env=...`` and when the run will be on the CPU
    (``device=cpu``, or ``auto`` without CUDA), train the small real configuration ``env=cpu_small``. A config chosen
    with ``--config-name`` (e.g. a ``conf/paper`` row) keeps its own env."""
    if cuda_available is None:
        cuda_available = torch.cuda.is_available()
    given = _overrides(argv)
    if "env" in given or _config_name(argv) not in (None, "config"):
        return []
    device = given.get("device", "auto")
    on_cpu = device == "cpu" or (device == "auto" and not cuda_available)
    return [f"env={CPU_ENV_PRESET}"] if on_cpu else []


def parkour_arch_overrides(argv: Sequence[str], conf_dir: Path = CONF_DIR) -> tuple[list[str], str | None]:
    """For a Parkour env (``env=parkour_*``), the Go1 preset of the chosen architecture: ``arch=<name>`` (or the
    default ``mlp``) becomes ``arch=<name>_parkour`` when ``conf/arch/<name>_parkour.yaml`` exists (MTBench's Go1
    network sizes and per-architecture PPO settings). Returns the new argument list and a note (``None`` when
    nothing changed)."""
    given = _overrides(argv)
    env = given.get("env", "")
    if not env.startswith("parkour"):
        return list(argv), None
    arch = given.get("arch", "mlp")
    if arch.endswith("_parkour") or not (conf_dir / "arch" / f"{arch}_parkour.yaml").is_file():
        return list(argv), None
    out = [a for a in argv if not (a.split("=", 1)[0].lstrip("+~") == "arch" and "=" in a)]
    note = f"arch={arch} -> arch={arch}_parkour (the Go1 preset of {arch} for Parkour envs)"
    return [*out, f"arch={arch}_parkour"], note


def resume_dir_overrides(argv: Sequence[str]) -> list[str]:
    """A resumed run continues in its own run directory: ``resume=<run>/checkpoints/<file>`` adds
    ``hydra.run.dir=<run>`` (unless ``hydra.run.dir`` is given), so Hydra does not open a new
    ``outputs/<date>/<time>/``."""
    given = _overrides(argv)
    if not given.get("resume") or given["resume"] == "null" or "hydra.run.dir" in given:
        return []
    ckpt = Path(given["resume"]).absolute()
    run_dir = ckpt.parent.parent if ckpt.parent.name == "checkpoints" else ckpt.parent
    return [f"hydra.run.dir={run_dir}"]


def make_logger(cfg: DictConfig) -> Any:
    """``mtbench.logging.MCAPLogger`` (``logging.logger=mcap``; a resumed run appends a segment to its log) or
    ``None``."""
    kind = str(cfg.logging.get("logger", "mcap"))
    if kind not in LOGGERS:
        raise ValueError(f"unknown logging.logger {kind!r}; valid choices: {list(LOGGERS)}")
    if kind == "none":
        return None
    from ..logging import MCAPLogger

    return MCAPLogger(str(cfg.logging.exp_name), str(cfg.logging.log_dir),
                      if_exists="append" if cfg.get("resume") else "error")


def _close_logger(logger: Any) -> None:
    if logger is None:
        return
    close = getattr(logger, "close", None) or getattr(getattr(logger, "experiment", None), "close", None)
    if callable(close):
        close()


def say(*args: Any, **kwargs: Any) -> None:
    """``print`` on rank 0 only (torchrun: one process prints; every process in a single-process run)."""
    if distributed.rank() == 0:
        print(*args, **kwargs)


def train_stage(cfg: DictConfig, env: Any = None) -> TrainingLoop:
    """Build one run (:func:`~mtbench.trainer.builder.build_trainer`), attach the logger, train, close the env and
    the logger, print the per-task table; returns the trainer."""
    trainer = build_trainer(cfg, env=env)
    cfg = trainer.config
    # after the env is built: a failing build leaves no empty log file behind; torchrun: rank 0 logs
    logger = make_logger(cfg) if distributed.rank() == 0 else None
    if logger is not None:
        trainer.add_hook(MetricsLogger(logger), before=Checkpointer)
    say(
        f"mtbench | {cfg.loss.name} arch={cfg.arch.name} grad={cfg.grad.name} env={cfg.env.name} "
        f"tasks={trainer.num_tasks} envs={trainer.total_envs} horizon={trainer.horizon} device={trainer.env.device} | "
        f"{trainer.total_iterations} iterations x {trainer.frames_per_batch:,} frames ({trainer.update_summary()}) | "
        f"run {cfg.logging.exp_name}" + (f" | {trainer.world_size} processes" if trainer.world_size > 1 else ""),
        flush=True,
    )
    if trainer.iteration or trainer.rollout.steps_done:
        say(f"resumed from {cfg.resume} at iteration {trainer.iteration} ({trainer.frames:,} frames)", flush=True)
    elif cfg.get("pretrained"):
        reset = cfg.get("pretrained_log_std")
        note = "" if reset is None else f" (policy log-std set to {reset:g}: sigma = {math.exp(reset):.3g})"
        say(f"starting from the weights of {cfg.pretrained}{note}", flush=True)
    try:
        trainer.train()
    finally:
        trainer.env.close()
        _close_logger(logger)
    guard = trainer.get_hook(NonFiniteGuard)
    skipped = guard.skipped_total if guard is not None else 0
    say(f"\nPer-task {trainer.window.metric} over the last {trainer.window.window} iterations "
        f"({trainer.frames:,} frames, {skipped} skipped updates):")
    say(trainer.success_table(), flush=True)
    checkpointer = trainer.get_hook(Checkpointer)
    if checkpointer is not None and checkpointer.last_path is not None:
        say(f"checkpoint: {checkpointer.last_path}")
    return trainer


def run(cfg: DictConfig, env: Any = None) -> TrainingLoop | None:
    """Train the run of ``cfg``. A Parkour run without ``pretrained=`` first pre-trains on flat ground (or reuses
    the pre-training of its architecture; :mod:`~mtbench.trainer.pretraining`), then fine-tunes from it. Returns the
    trainer of the last stage that ran, ``None`` when a stop request ended the pre-training."""
    cfg = as_config(cfg)
    if distributed.context_from_environment() is None:
        return _run_stages(cfg, env)
    check_config(cfg)
    join_run(cfg, resolve_device(cfg.get("device", "auto")))  # torchrun: one clear error before anything starts
    try:
        return _run_stages(cfg, env)
    finally:
        distributed.shutdown()


def _run_stages(cfg: DictConfig, env: Any) -> TrainingLoop | None:
    if needs_flat_stage(cfg):
        check_config(cfg)  # before a long pre-training: the fine-tuning's config errors show now
        say("== stage 1/2: flat-ground pre-training", flush=True)
        path = pretrain_flat(cfg, train_stage, echo=say)
        if path is None:
            return None
        with open_dict(cfg):
            cfg.pretrained = str(path)
        say(f"== stage 2/2: {cfg.env.name}", flush=True)
    return train_stage(cfg, env)


def main_argv() -> list[str]:
    """``sys.argv`` with :func:`parkour_arch_overrides` applied, plus :func:`cpu_default_overrides` and
    :func:`resume_dir_overrides` (called by ``examples/train.py`` before Hydra parses)."""
    args, note = parkour_arch_overrides(sys.argv[1:])
    context = distributed.context_from_environment()  # before the process group: torchrun's variables
    if note is not None and (context is None or context.is_main):  # torchrun: one process prints
        print(note, flush=True)
    overrides = [*args, *cpu_default_overrides(args), *resume_dir_overrides(args)]
    # Hydra's argument parser takes the overrides as one run of positional arguments: keep its flags
    # (``--cfg job``, ``--config-name X``, ``-m``) in front of all of them
    is_override = [("=" in a and not a.startswith("-")) for a in overrides]
    flags = [a for a, o in zip(overrides, is_override) if not o]
    return [sys.argv[0], *flags, *(a for a, o in zip(overrides, is_override) if o)]


__all__ = ["CPU_ENV_PRESET", "cpu_default_overrides", "main_argv", "make_logger", "parkour_arch_overrides",
           "resume_dir_overrides", "run", "say", "train_stage"]
