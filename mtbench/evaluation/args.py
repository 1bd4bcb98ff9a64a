"""Command-line arguments of ``examples/eval.py``: Hydra-style ``key=value`` pairs, validated one by one."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any, Sequence

import torch

BOOL_WORDS = {"true": True, "1": True, "yes": True, "on": True, "false": False, "0": False, "no": False, "off": False}
DEVICE_CHOICES = "auto, cpu, cuda, cuda:<index>"
MAX_VIDEO_SIDE = 4096


class EvalArgumentError(ValueError):
    """A bad ``examples/eval.py`` argument; the message names the parameter and its valid choices or range."""


@dataclasses.dataclass
class EvalArgs:
    """Options of an evaluation run (see ``docs/evaluation.md``).

    Attributes:
        checkpoint: checkpoint file written by ``Trainer.save`` (e.g. ``.../checkpoints/final.pt``).
        episodes: episodes per task (>= 1) for each evaluation (sampled and deterministic).
        deterministic: run only the deterministic evaluation (actions = Gaussian mean clamped to the env's action
            bounds; loss=pqn: the greedy bins).
        video: render one video per task (first world(s) of each task block, first episode of the
            deterministic evaluation).
        device: ``auto`` (cuda if available), ``cpu``, ``cuda`` or ``cuda:<index>``.
        num_envs: worlds in total (split over the tasks as in training); ``None`` = ``episodes * num_tasks``.
        seed: env and sampling seed; ``None`` = the training seed + 1 (worlds the policy was not trained on).
        out: output directory; ``None`` = ``<checkpoint dir>/eval``.
        video_frames: frames per video (1 .. episode length / ``video_every``; ``None`` = the whole first episode in
            at most 150 frames).
        video_every: record every k-th step (``None``: 1 where ``video_frames`` is given, else the smallest k that
            fits the whole first episode into 150 frames: 1 for Meta-World's 150 steps, 14 for Parkour's 2000).
        video_size: ``(width, height)``; ``None`` = 320x240 on CUDA, 160x120 on the CPU.
        video_fps: frame rate of the written videos.
        video_grid: 1 (first world of each task) or 2 (2x2 grid of its first four worlds).
        env_overrides: ``env.name=...`` / ``env.overrides.<key>=...`` items (Hydra-style values: lists, booleans,
            numbers) merged into the run's env config, e.g. other tasks or terrains, or Parkour worlds all on row 0
            (``env.overrides.curriculum=true env.overrides.max_init_level=0``); empty: the run's own env.
    """

    checkpoint: Path
    episodes: int = 10
    deterministic: bool = False
    video: bool = False
    device: str = "auto"
    num_envs: int | None = None
    seed: int | None = None
    out: Path | None = None
    video_frames: int | None = None
    video_every: int | None = None
    video_size: tuple[int, int] | None = None
    video_fps: int = 30
    video_grid: int = 1
    env_overrides: tuple[str, ...] = ()


ENV_KEY = re.compile(r"^env\.(name|overrides\.[A-Za-z_][A-Za-z0-9_]*)$")
KEYS = tuple(f.name for f in dataclasses.fields(EvalArgs) if f.name != "env_overrides")
USAGE = (
    "usage: python examples/eval.py checkpoint=PATH [episodes=N] [deterministic=true|false] [video=true|false] "
    "[device=auto|cpu|cuda|cuda:I] [num_envs=N] [seed=S] [out=DIR] [video_frames=N] [video_every=K] [video_size=WxH] "
    "[video_fps=N] [video_grid=1|2] [env.name=NAME|[T1,T2,...]] [env.overrides.KEY=VALUE ...]"
)


def _int(key: str, text: str, low: int | None = None, high: int | None = None) -> int:
    try:
        value = int(text, 10)
    except ValueError:
        raise EvalArgumentError(f"{key}={text!r} is not an integer; {key} must be {_range(low, high)}") from None
    if (low is not None and value < low) or (high is not None and value > high):
        raise EvalArgumentError(f"{key}={value} is out of range; {key} must be {_range(low, high)}")
    return value


def _range(low: int | None, high: int | None) -> str:
    if low is not None and high is not None:
        return f"an integer in [{low}, {high}]"
    if low is not None:
        return f"an integer >= {low}"
    return "an integer"


def _bool(key: str, text: str) -> bool:
    value = BOOL_WORDS.get(text.strip().lower())
    if value is None:
        raise EvalArgumentError(f"{key}={text!r} is not a boolean; valid choices: true, false (also 1/0, yes/no)")
    return value


def _device(text: str) -> str:
    value = text.strip().lower()
    if value in ("auto", "cpu", "cuda") or re.fullmatch(r"cuda:\d+", value):
        if value.startswith("cuda") and not torch.cuda.is_available():
            raise EvalArgumentError(f"device={text!r}: CUDA is not available on this machine; valid choices here: "
                                    "auto, cpu")
        if value.startswith("cuda:") and int(value[5:]) >= torch.cuda.device_count():
            raise EvalArgumentError(f"device={text!r}: no such GPU; valid indices: 0..{torch.cuda.device_count() - 1}")
        return value
    raise EvalArgumentError(f"device={text!r} is not a valid device; valid choices: {DEVICE_CHOICES}")


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if match is None:
        raise EvalArgumentError(f"video_size={text!r} is not WIDTHxHEIGHT; e.g. video_size=320x240 (each side in "
                                f"[16, {MAX_VIDEO_SIDE}])")
    w, h = int(match.group(1)), int(match.group(2))
    if not (16 <= w <= MAX_VIDEO_SIDE and 16 <= h <= MAX_VIDEO_SIDE):
        raise EvalArgumentError(f"video_size={text!r} is out of range; each side must be in [16, {MAX_VIDEO_SIDE}]")
    return w, h


def _checkpoint(text: str) -> Path:
    path = Path(text).expanduser()
    if not text.strip():
        raise EvalArgumentError("checkpoint= is empty; give the path of a checkpoint file written by training "
                                "(e.g. outputs/<date>/<time>/checkpoints/final.pt)")
    if path.is_dir():
        found = sorted(p.name for p in path.glob("*.pt"))
        hint = f" (it holds {', '.join(found)})" if found else ""
        raise EvalArgumentError(f"checkpoint={text!r} is a directory{hint}; give a checkpoint file, e.g. "
                                f"checkpoint={path / 'final.pt'}")
    if not path.exists():
        raise EvalArgumentError(f"checkpoint={text!r}: no such file; give the path of a checkpoint file written by "
                                "training (e.g. outputs/<date>/<time>/checkpoints/final.pt)")
    if not path.is_file():
        raise EvalArgumentError(f"checkpoint={text!r} is not a regular file")
    return path


def parse_args(argv: Sequence[str]) -> EvalArgs:
    """``["checkpoint=PATH", "episodes=5", ...]`` -> :class:`EvalArgs`; raises :class:`EvalArgumentError` naming
    the parameter and its valid choices or range."""
    values: dict[str, Any] = {}
    env_overrides: dict[str, str] = {}
    for arg in argv:
        if "=" not in arg:
            raise EvalArgumentError(f"argument {arg!r} is not key=value; valid keys: {', '.join(KEYS)}\n{USAGE}")
        key, text = arg.split("=", 1)
        key = key.strip().lstrip("+")
        if key.startswith("env."):
            if not ENV_KEY.match(key):
                raise EvalArgumentError(f"unknown parameter {key!r}; the env is changed with env.name=... (tasks or "
                                        f"terrains) and env.overrides.<key>=... (make_env arguments)")
            if key in env_overrides:
                raise EvalArgumentError(f"parameter {key!r} is given twice")
            if not text.strip():
                raise EvalArgumentError(f"{key}= is empty; give a value")
            env_overrides[key] = text
            continue
        if key not in KEYS:
            raise EvalArgumentError(f"unknown parameter {key!r}; valid keys: {', '.join(KEYS)}")
        if key in values:
            raise EvalArgumentError(f"parameter {key!r} is given twice")
        if key == "checkpoint":
            values[key] = _checkpoint(text)
        elif key == "episodes":
            values[key] = _int(key, text, low=1)
        elif key in ("deterministic", "video"):
            values[key] = _bool(key, text)
        elif key == "device":
            values[key] = _device(text)
        elif key == "num_envs":
            values[key] = _int(key, text, low=1)
        elif key == "seed":
            values[key] = _int(key, text, low=0, high=2**63 - 1)
        elif key == "out":
            if not text.strip():
                raise EvalArgumentError("out= is empty; give a directory (created if missing)")
            values[key] = Path(text).expanduser()
        elif key in ("video_frames", "video_every"):
            values[key] = _int(key, text, low=1)
        elif key == "video_size":
            values[key] = _size(text)
        elif key == "video_fps":
            values[key] = _int(key, text, low=1, high=240)
        elif key == "video_grid":
            values[key] = _int(key, text, low=1, high=2)
    if "checkpoint" not in values:
        raise EvalArgumentError(f"missing parameter 'checkpoint' (a checkpoint file written by training)\n{USAGE}")
    return EvalArgs(**values, env_overrides=tuple(f"{k}={v}" for k, v in env_overrides.items()))


__all__ = ["BOOL_WORDS", "DEVICE_CHOICES", "EvalArgs", "EvalArgumentError", "KEYS", "USAGE", "parse_args"]
