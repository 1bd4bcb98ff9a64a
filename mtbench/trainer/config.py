"""Validation of the training config (one clear ``ValueError`` per bad value), device choice, run paths and
the warning for CPU runs that are far too big."""

from __future__ import annotations

import math
import re
import time
import warnings
from pathlib import Path
from typing import Any, Mapping

import torch
from omegaconf import DictConfig, OmegaConf, open_dict

from ..objectives.sac import ALPHA_LOSSES

LOSSES = ("ppo", "grpo", "sac", "pqn")
LR_SCHEDULES = ("fixed", "adaptive")
# when the adaptive learning rate adapts and against what its KL is measured: "minibatch" (after every update, KL to
# the behaviour policy) or "standard" (rl_games schedule_type standard: after every epoch, on the epoch's mean KL,
# each minibatch's measured against the policy one epoch earlier)
LR_SCHEDULE_TYPES = ("minibatch", "standard")
LOGGERS = ("mcap", "none")
PROGRESS_MODES = ("auto", "tqdm", "line", "none")
MATMUL_PRECISIONS = ("highest", "high", "medium")
DEVICE_CHOICES = "'auto', 'cpu', 'cuda' or 'cuda:<index>'"
# measured on a 2-core CPU (cpu_small: 48 Meta-World worlds, 45 ms per env step incl. the policy)
CPU_SECONDS_PER_WORLD_STEP = 1e-3
CPU_SLOW_ITERATION_S = 60.0


def as_config(cfg: Mapping[str, Any] | DictConfig) -> DictConfig:
    """``cfg`` as an OmegaConf ``DictConfig``."""
    return cfg if isinstance(cfg, DictConfig) else OmegaConf.create(dict(cfg))


def resolve_device(device: str | torch.device | None) -> torch.device:
    """``"auto"``/``None`` -> ``cuda`` if available else ``cpu``; ``cpu``, ``cuda``, ``cuda:<index>`` as given."""
    if device is None or str(device) == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    text = str(device)
    if not re.fullmatch(r"cpu|cuda(:\d+)?", text):
        raise ValueError(f"device={text!r} is not supported; valid choices: {DEVICE_CHOICES}")
    dev = torch.device(text)
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device={text!r} requested but CUDA is not available; valid choices here: 'auto', 'cpu'")
    return dev


def _int(value: Any, name: str, minimum: int, hint: str = "", *, optional: bool = False) -> int | None:
    """``value`` as an int >= ``minimum`` (``None`` allowed when ``optional``), else one ``ValueError``."""
    if value is None and optional:
        return None
    ok = isinstance(value, int) and not isinstance(value, bool) and value >= minimum
    if not ok:
        what = f"an integer >= {minimum}" + (" or null" if optional else "")
        raise ValueError(f"{name} must be {what}{hint}; got {value!r}")
    return int(value)


#: valid ``pretrained_log_std`` values (sigma from 0.0067 to 7.4)
PRETRAINED_LOG_STD_RANGE = (-5.0, 2.0)


def _choice(value: Any, name: str, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}; valid choices: {list(choices)}")
    return str(value)


def check_config(cfg: DictConfig) -> None:
    """Validate the top-level, ``loss``, ``checkpoint`` and ``logging`` values a run reads (before anything is
    built); every error names the parameter and its valid range or choices."""
    seed = cfg.get("seed", 0)
    if not (isinstance(seed, int) and not isinstance(seed, bool)):
        raise ValueError(f"seed must be an integer; got {seed!r}")
    resolve_device(cfg.get("device", "auto"))
    _int(cfg.get("total_frames"), "total_frames", 1, " (null: use max_iterations)", optional=True)
    if cfg.get("total_frames") is None:
        _int(cfg.get("max_iterations"), "max_iterations", 1)
    _int(cfg.get("torch_threads"), "torch_threads", 1, " (null: torch's default)", optional=True)
    _choice(cfg.get("matmul_precision", "high"), "matmul_precision", MATMUL_PRECISIONS)
    _int(cfg.get("success_window", 5), "success_window", 1)
    _int(cfg.get("max_nonfinite_iterations", 10), "max_nonfinite_iterations", 1)
    ck = cfg.get("checkpoint") or {}
    _int(ck.get("every", 0), "checkpoint.every", 0, " (0: only the final checkpoint)")
    _int(ck.get("keep_last", 0), "checkpoint.keep_last", 0, " (0: keep all)")
    lc = cfg.loss
    _choice(lc.get("name"), "loss.name", LOSSES)
    if lc.get("name") == "sac":
        check_sac_loss(lc)
    else:
        _choice(lc.get("lr_schedule", "fixed"), "loss.lr_schedule", LR_SCHEDULES)
        _choice(lc.get("lr_schedule_type", "minibatch"), "loss.lr_schedule_type", LR_SCHEDULE_TYPES)
        for key in ("horizon", "epochs", "minibatch_size"):
            _int(lc.get(key), f"loss.{key}", 1)
    clip_actions = lc.get("clip_actions", False)
    if not isinstance(clip_actions, bool):
        raise ValueError(f"loss.clip_actions must be true or false; got {clip_actions!r}")
    if clip_actions and lc.get("name") not in ("ppo", "grpo"):
        raise ValueError(f"loss.clip_actions=true applies to loss=ppo|grpo (Gaussian policies); loss={lc.get('name')} "
                         "acts within its bounds already (sac: tanh-squashed, pqn: discrete bins)")
    if lc.get("name") == "pqn":
        from .pqn import check_pqn_config

        check_pqn_config(lc)
    lg = cfg.get("logging") or {}
    _choice(str(lg.get("logger", "mcap")), "logging.logger", LOGGERS)
    _choice(str(lg.get("progress", "auto")), "logging.progress", PROGRESS_MODES)
    _int(lg.get("print_every", 1), "logging.print_every", 1)
    env = cfg.get("env") or {}
    if "num_envs" in env:
        _int(env.num_envs, "env.num_envs", 1)
    pre = cfg.get("pretrain") or {}
    _int(pre.get("iterations", 0), "pretrain.iterations", 0, " (0: no flat-ground pre-training)")
    _int(pre.get("num_envs"), "pretrain.num_envs", 1, " (null: env.num_envs)", optional=True)
    pre_seed = pre.get("seed", 0)
    if not (isinstance(pre_seed, int) and not isinstance(pre_seed, bool)):
        raise ValueError(f"pretrain.seed must be an integer; got {pre_seed!r}")
    pretrained = cfg.get("pretrained")
    if pretrained is not None and not Path(str(pretrained)).is_file():
        what = "is a directory" if Path(str(pretrained)).is_dir() else "does not exist"
        raise ValueError(f"pretrained={pretrained} {what}; give a checkpoint file written by mtbench (e.g. "
                         "runs/pretrained/<arch>-<key>/checkpoints/final.pt) or null")
    _number(cfg.get("pretrained_log_std"), "pretrained_log_std", PRETRAINED_LOG_STD_RANGE[0],
            PRETRAINED_LOG_STD_RANGE[1], optional=True)
    if cfg.get("pretrained_log_std") is not None and lc.get("name") in ("sac", "pqn"):
        raise ValueError(f"pretrained_log_std applies to loss=ppo|grpo (a Gaussian policy with a state-independent "
                         f"log-std); loss={lc.get('name')} has none: set pretrained_log_std=null")
    resume = cfg.get("resume")
    if resume is not None and Path(str(resume)).is_dir():
        raise ValueError(f"resume={resume} is a directory; give a checkpoint file written by mtbench (e.g. "
                         f"{Path(str(resume)) / 'checkpoints' / 'last.pt'})")


def _number(value: Any, name: str, low: float, high: float = math.inf, *, low_open: bool = False,
            optional: bool = False) -> None:
    """``value`` as a finite number in ``[low, high]`` (``(low, high]`` when ``low_open``), else one ``ValueError``."""
    if value is None and optional:
        return
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    ok = ok and (value > low if low_open else value >= low) and value <= high
    if not ok:
        interval = f"{'(' if low_open else '['}{low}, {high}{']' if math.isfinite(high) else ')'}"
        raise ValueError(f"{name} must be a number in {interval}{' or null' if optional else ''}; got {value!r}")


def check_sac_loss(lc: Any) -> None:
    """Validate the ``loss=sac`` values (``conf/loss/sac.yaml``): sizes, n-step, learning rates, temperatures."""
    for key in ("horizon", "gradient_steps_per_iteration", "batch_size", "replay_buffer_size", "nstep"):
        _int(lc.get(key), f"loss.{key}", 1)
    _int(lc.get("warmup_steps"), "loss.warmup_steps", 0)
    _int(lc.get("num_qvalue_nets", 2), "loss.num_qvalue_nets", 1)
    if lc.batch_size > lc.replay_buffer_size:
        raise ValueError(f"loss.batch_size={lc.batch_size} must not exceed loss.replay_buffer_size="
                         f"{lc.replay_buffer_size} (each update samples one batch from the buffer)")
    _number(lc.get("gamma"), "loss.gamma", 0.0, 1.0, low_open=True)
    for key in ("actor_lr", "critic_lr", "alpha_lr", "init_alpha"):
        _number(lc.get(key), f"loss.{key}", 0.0, low_open=True)
    _number(lc.get("critic_tau"), "loss.critic_tau", 0.0, 1.0, low_open=True)
    _number(lc.get("target_entropy_coef"), "loss.target_entropy_coef", 0.0)
    _number(lc.get("max_grad_norm"), "loss.max_grad_norm", 0.0, low_open=True, optional=True)
    _number(lc.get("adam_eps", 1e-8), "loss.adam_eps", 0.0, low_open=True)
    if lc.get("normalize_value"):
        raise ValueError("loss.normalize_value=true is not supported by loss=sac: MTBench's SAC config sets it, but "
                         "its SAC model never applies the value statistics it creates (no effect to reproduce); "
                         "remove it")
    _choice(lc.get("alpha_loss"), "loss.alpha_loss", ALPHA_LOSSES)
    for key in ("learnable_temperature", "disentangled_alpha", "normalize_input", "replay_in_checkpoint"):
        if not isinstance(lc.get(key), bool):
            raise ValueError(f"loss.{key} must be true or false; got {lc.get(key)!r}")
    bounds = lc.get("log_std_bounds")
    if not (OmegaConf.is_list(bounds) or isinstance(bounds, (list, tuple))) or len(bounds) != 2 or not all(
            isinstance(b, (int, float)) and not isinstance(b, bool) for b in bounds) or not bounds[0] < bounds[1]:
        raise ValueError(f"loss.log_std_bounds must be [min, max] with min < max; got {bounds!r}")


def effective_minibatch_size(num_envs: int, horizon: int, minibatch_size: int) -> int:
    """``loss.minibatch_size`` when it divides the batch ``num_envs * horizon``, the batch when it is larger
    (one minibatch); else ``ValueError``."""
    batch = num_envs * horizon
    size = min(int(minibatch_size), batch)
    if size < 1 or batch % size:
        raise ValueError(f"loss.minibatch_size={minibatch_size} must divide the batch num_envs*horizon = "
                         f"{num_envs}*{horizon} = {batch} (or be >= it: one minibatch)")
    return size


def total_iterations(cfg: DictConfig, frames_per_batch: int) -> int:
    """``ceil(total_frames / frames_per_batch)`` when ``total_frames`` is set, else ``max_iterations``."""
    if cfg.get("total_frames") is not None:
        return max(1, math.ceil(int(cfg.total_frames) / frames_per_batch))
    return int(cfg.max_iterations)


def hydra_output_dir() -> Path:
    """Hydra's run directory when running under Hydra, else the working directory."""
    try:
        from hydra.core.hydra_config import HydraConfig

        if HydraConfig.initialized():
            return Path(HydraConfig.get().runtime.output_dir)
    except ImportError:  # pragma: no cover
        pass
    return Path.cwd()


def _hydra_choice(group: str, default: str) -> str:
    try:
        from hydra.core.hydra_config import HydraConfig

        if HydraConfig.initialized():
            return str(HydraConfig.get().runtime.choices.get(group, default))
    except ImportError:  # pragma: no cover
        pass
    return default


def resolve_run_paths(cfg: DictConfig, resumed: Mapping[str, Any] | None = None) -> None:
    """Fill the run's paths in place (so that checkpoints record them):

    * ``logging.exp_name``: given, else the resumed run's, else ``<loss>-<arch>-<grad>-<env>-s<seed>-<time>``;
    * ``logging.log_dir``: given, else the resumed run's, else ``runs/`` in the working directory (absolute);
    * ``checkpoint.dir``: given, else the directory of the resumed checkpoint, else ``<run dir>/checkpoints``.

    ``resumed``: the config stored in the checkpoint given as ``resume`` (a resumed run continues in its own
    directories: same checkpoints folder, same MCAP log).
    """
    saved_logging = (resumed or {}).get("logging") or {}
    with open_dict(cfg):
        if not cfg.logging.get("exp_name"):
            name = saved_logging.get("exp_name")
            if not name:
                env = _hydra_choice("env", str(cfg.env.name))
                name = (f"{cfg.loss.name}-{cfg.arch.name}-{cfg.grad.name}-{env}-s{cfg.seed}-"
                        f"{time.strftime('%Y%m%d-%H%M%S')}")
            cfg.logging.exp_name = str(name)
        if not cfg.logging.get("log_dir"):
            cfg.logging.log_dir = str(saved_logging.get("log_dir") or Path.cwd() / "runs")
        cfg.logging.log_dir = str(Path(cfg.logging.log_dir).absolute())
        if not cfg.checkpoint.get("dir"):
            if cfg.get("resume"):
                cfg.checkpoint.dir = str(Path(str(cfg.resume)).absolute().parent)
            else:
                cfg.checkpoint.dir = str(hydra_output_dir().absolute() / "checkpoints")


def warn_if_cpu_run_too_big(device: torch.device, num_envs: int, horizon: int) -> float:
    """On the CPU, warn when one iteration would take longer than ``CPU_SLOW_ITERATION_S``; returns the
    estimate in seconds (``CPU_SECONDS_PER_WORLD_STEP`` per world and env step: the rollout's share, the update
    adds to it)."""
    if device.type != "cpu":
        return 0.0
    estimate = CPU_SECONDS_PER_WORLD_STEP * num_envs * horizon
    if estimate > CPU_SLOW_ITERATION_S:
        warnings.warn(
            f"CPU run with {num_envs:,} worlds x {horizon} steps per iteration: about {estimate / 60:.0f} min per "
            f"iteration on a small CPU (~{CPU_SECONDS_PER_WORLD_STEP * 1e3:.0f} ms per world step; the update adds to "
            "it). Use a GPU, or env=cpu_small / a smaller env.num_envs for a CPU run.",
            RuntimeWarning,
            stacklevel=3,
        )
    return estimate


__all__ = [
    "LOGGERS",
    "LOSSES",
    "LR_SCHEDULES",
    "LR_SCHEDULE_TYPES",
    "MATMUL_PRECISIONS",
    "PROGRESS_MODES",
    "as_config",
    "check_config",
    "check_sac_loss",
    "effective_minibatch_size",
    "hydra_output_dir",
    "resolve_device",
    "resolve_run_paths",
    "total_iterations",
    "warn_if_cpu_run_too_big",
]
