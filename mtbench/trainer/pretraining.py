"""Flat-ground pre-training as the first stage of a Parkour run, and starting a run from pre-trained weights
(``pretrained=PATH``).

MTBench (``exec/go1_exps/flat``) trains every architecture for 1000 PPO iterations on all-flat terrain
(``final_go1_easy`` with every column flat) and starts every Parkour-easy/hard/hard-cl run from that checkpoint;
PCGrad, CAGrad and FAMO start from the plain (vanilla) architecture's. Here a Parkour run without ``pretrained=``
does this by itself:

1. :func:`flat_stage_config`: the run's config with ``env.name=parkour_flat`` (same worlds and env overrides, no
   curriculum), ``grad=none``, ``pretrain.iterations`` iterations and ``pretrain.seed``;
2. :func:`stage_key`: a SHA-256 over what shapes the weights (architecture, loss, flat env, iterations, seed, robot
   model version); the gradient method and the run's own setting, seed and length are not part of it, so all
   Parkour settings and gradient methods of one architecture share one pre-training, as in the original;
3. :func:`pretrain_flat`: ``<pretrain.dir>/<arch>-<key>/checkpoints/final.pt`` is reused when it exists; else the
   stage is trained there (continuing from its ``last.pt`` after a crash or kill), under a file lock so that runs
   started in parallel wait for one pre-training instead of repeating it.

:func:`load_pretrained` copies the networks of any mtbench checkpoint into a new run (its ``*_network_params``;
not the loss coefficients, the value statistics, the optimizer or the counters; the observation statistics when
both runs normalise observations), checking that the architecture fits.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator

import torch
from omegaconf import DictConfig, OmegaConf, open_dict

from ..utils import distributed
from .checkpoint import CheckpointError, load_checkpoint

if TYPE_CHECKING:
    from .trainer import Trainer

FLAT_SETTING = "parkour_flat"
# env overrides that belong to the fine-tuning setting, not to the flat stage
STAGE_DROPPED_OVERRIDES = ("curriculum", "easy", "max_init_level")
STAGE_FILE = "stage.json"


def needs_flat_stage(cfg: DictConfig) -> bool:
    """Whether the run starts with the flat pre-training stage: a Parkour env other than ``parkour_flat``, no
    ``pretrained`` weights, no ``resume`` (a resumed run has its weights) and ``pretrain.iterations > 0``."""
    from ..envs import is_parkour

    name = cfg.env.name
    name = list(name) if OmegaConf.is_list(name) or isinstance(name, (list, tuple)) else str(name)
    if not is_parkour(name) or name == FLAT_SETTING or cfg.get("pretrained") or cfg.get("resume"):
        return False
    return int((cfg.get("pretrain") or {}).get("iterations", 0) or 0) > 0


def _plain(cfg: DictConfig | Any) -> Any:
    return OmegaConf.to_container(cfg, resolve=True) if OmegaConf.is_config(cfg) else cfg


def flat_stage_config(cfg: DictConfig) -> DictConfig:
    """The config of ``cfg``'s flat pre-training stage (paths not filled in: see :func:`pretrain_flat`)."""
    pre = cfg.get("pretrain") or {}
    stage = OmegaConf.create(_plain(cfg))
    overrides = dict(_plain(cfg.env.get("overrides")) or {})
    for key in STAGE_DROPPED_OVERRIDES:
        overrides.pop(key, None)
    with open_dict(stage):
        stage.env = {"name": FLAT_SETTING, "num_envs": int(pre.get("num_envs") or cfg.env.num_envs),
                     "overrides": overrides}
        stage.grad = {"name": "none"}
        stage.max_iterations = int(pre.get("iterations", 0))
        stage.total_frames = None
        stage.seed = int(pre.get("seed", 0))
        stage.pretrained = None
        stage.pretrained_log_std = None  # the fine-tuning's reset of the stage's sigma, not the stage's
        stage.resume = None
    return stage


def stage_key(stage: DictConfig) -> str:
    """SHA-256 (hex) of what shapes the pre-trained weights: ``arch``, ``loss``, the flat env, iterations, seed and
    the robot model's version (``robot.model_version``: a physics change invalidates older stages). The env overrides
    ``robot_inertia``, ``robot_armature``, ``robot_integrator``, ``robot_contact_timeconst`` and
    ``robot_collision_pieces`` enter through the model version, not as overrides: a model keeps its key whether its
    values are named or left to the env's defaults, and a ``"urdf"`` stage never shares a ``"menagerie"`` one."""
    from ..envs.parkour.robot import (DEFAULT_COLLISION_PIECES, DEFAULT_CONTACT_TIMECONST, DEFAULT_INERTIAL_MODEL,
                                      DEFAULT_INTEGRATOR, model_version)

    material = {key: _plain(stage.get(key)) for key in ("arch", "loss", "env", "max_iterations", "seed")}
    overrides = (material.get("env") or {}).get("overrides") or {}
    # popped from the material's own copy
    inertia = overrides.pop("robot_inertia", DEFAULT_INERTIAL_MODEL)
    armature = overrides.pop("robot_armature", None)
    integrator = overrides.pop("robot_integrator", DEFAULT_INTEGRATOR)
    contact = overrides.pop("robot_contact_timeconst", DEFAULT_CONTACT_TIMECONST)
    pieces = overrides.pop("robot_collision_pieces", DEFAULT_COLLISION_PIECES)
    material["robot_model"] = model_version(inertia, armature, integrator, contact, pieces)
    return hashlib.sha256(json.dumps(material, sort_keys=True).encode()).hexdigest()


def pretrain_root(cfg: DictConfig) -> Path:
    """``pretrain.dir``, else ``<logging.log_dir>/pretrained`` (``runs/pretrained`` in the working directory)."""
    given = (cfg.get("pretrain") or {}).get("dir")
    if given:
        return Path(str(given)).absolute()
    log_dir = (cfg.get("logging") or {}).get("log_dir") or Path.cwd() / "runs"
    return Path(str(log_dir)).absolute() / "pretrained"


def stage_directory(cfg: DictConfig, stage: DictConfig | None = None) -> Path:
    """``<pretrain root>/<arch name>-<first 12 hex digits of the key>``."""
    stage = flat_stage_config(cfg) if stage is None else stage
    return pretrain_root(cfg) / f"{stage.arch.name}-{stage_key(stage)[:12]}"


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive ``flock`` on ``path`` (POSIX; elsewhere no lock)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+") as handle:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX
            yield
            return
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def pretrain_flat(cfg: DictConfig, train_stage: Callable[[DictConfig], "Trainer"],
                  echo: Callable[[str], None] = print) -> Path | None:
    """The final checkpoint of ``cfg``'s flat pre-training: reused when present, else trained with
    ``train_stage(stage_config)`` (which builds, trains and closes a run). ``None`` when the stage was stopped
    before its last iteration (Ctrl-C): running the same command again continues it."""
    stage = flat_stage_config(cfg)
    directory = stage_directory(cfg, stage)
    final = directory / "checkpoints" / "final.pt"
    main = distributed.rank() == 0  # torchrun: rank 0 holds the lock and decides, the other ranks follow
    with _locked(directory / ".lock") if main else contextlib.nullcontext():
        last = directory / "checkpoints" / "last.pt"
        reuse, resume = distributed.broadcast_object((final.is_file(), last.is_file()))
        if reuse:
            echo(f"flat pre-training: reusing {final} (arch={stage.arch.name}, {stage.max_iterations} iterations)")
            return final
        with open_dict(stage):
            stage.logging.exp_name = f"pretrain-{directory.name}"
            stage.logging.log_dir = str(directory)
            stage.checkpoint.dir = str(directory / "checkpoints")
            stage.resume = str(last) if resume else None
        if main:
            (directory / STAGE_FILE).write_text(json.dumps(
                {"key": stage_key(stage), **{k: _plain(stage.get(k)) for k in ("arch", "loss", "env",
                                                                                "max_iterations", "seed")}},
                indent=2, sort_keys=True))
        how = f"continuing from {last}" if stage.resume else "no checkpoint for this architecture yet"
        echo(f"flat pre-training: {stage.max_iterations} iterations on {FLAT_SETTING} ({how}) -> {directory}")
        trainer = train_stage(stage)
        distributed.barrier()  # torchrun: rank 0's final checkpoint is written
        if trainer.iteration < trainer.total_iterations or not final.is_file():
            echo(f"flat pre-training stopped at iteration {trainer.iteration}/{trainer.total_iterations}; run the "
                 "same command again to continue it")
            return None
    return final


def _loss_name(trainer: "Trainer") -> str:
    return str(trainer.config.loss.name) if trainer.config is not None else type(trainer.loss).__name__


def _network_keys(state: dict[str, Any]) -> list[str]:
    return [k for k in state if k.split(".", 1)[0].endswith("_network_params")]


def load_pretrained(trainer: "Trainer", path: str | os.PathLike[str], log_std: float | None = None) -> list[str]:
    """Copy the networks of the mtbench checkpoint ``path`` into ``trainer`` (every ``*_network_params`` entry of
    its loss; the observation statistics when both normalise observations). Returns the copied keys; raises one
    ``ValueError`` naming ``pretrained`` when the file is not a usable checkpoint or its networks do not fit.

    ``log_std`` (config ``pretrained_log_std``): afterwards set every state-independent log-std of the policy to this
    value (0: sigma = 1, the exploration noise of a fresh policy) instead of keeping the checkpoint's; a
    ``ValueError`` naming ``pretrained_log_std`` when the policy has none (SAC's and PQN's actors)."""
    from .trainer import observation_norm

    try:
        state = load_checkpoint(path)
    except CheckpointError as err:
        raise ValueError(f"pretrained={path}: {err.reason}") from err
    saved, current = state["loss"], trainer.loss.state_dict()
    keys = _network_keys(current)
    missing = [k for k in keys if k not in saved]
    wrong = [k for k in keys if k in saved and tuple(saved[k].shape) != tuple(current[k].shape)]
    if missing or wrong:
        theirs = ((state.get("config") or {}).get("arch") or {})
        ours = _plain(trainer.config.get("arch")) if trainer.config is not None else None
        example = (missing or wrong)[0]
        raise ValueError(
            f"pretrained={path}: its networks do not fit this run's ({len(missing)} entries missing, {len(wrong)} of "
            f"another shape, e.g. {example!r}); checkpoint arch={theirs}, this run arch={ours}. Pre-train with the "
            "same arch preset and an env with the same observation and action sizes"
        )
    std_keys = [k for k in keys if k.startswith("actor_network_params.") and k.endswith(".log_std")]
    if log_std is not None and not std_keys:
        raise ValueError(f"pretrained_log_std={log_std} needs a policy with a state-independent log-std "
                         f"(loss=ppo|grpo); this run's actor has none (loss={_loss_name(trainer)}); set "
                         "pretrained_log_std=null")
    with torch.no_grad():
        for key in keys:
            current[key].copy_(saved[key].to(current[key].device))
        if log_std is not None:
            for key in std_keys:
                current[key].fill_(float(log_std))
    norm = observation_norm(trainer.env)
    if norm is not None and state.get("obs_norm") is not None:
        norm.load_state_dict(state["obs_norm"])
    return keys


__all__ = [
    "FLAT_SETTING",
    "flat_stage_config",
    "load_pretrained",
    "needs_flat_stage",
    "pretrain_flat",
    "pretrain_root",
    "stage_directory",
    "stage_key",
]
