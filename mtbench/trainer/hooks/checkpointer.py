"""Periodic, final and stop checkpoints of a training loop."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from .base import TrainerHook


class Checkpointer(TrainerHook):
    """Writes ``ckpt_<iteration>.pt`` every ``every`` iterations (the newest ``keep_last`` kept), ``final.pt`` at
    the end of a complete run, and on a stop request (SIGINT/SIGTERM) a checkpoint of the state at that moment:
    ``ckpt_<iteration>.pt`` between iterations, ``ckpt_<iteration>_step<k>.pt`` after ``k`` env steps of the
    next rollout (the rollout continues there on resume). ``last.pt`` always points to the newest file
    (a hard link, else a copy).

    Args:
        directory: where the files go.
        every: iterations between periodic checkpoints (0: none).
        keep_last: periodic/stop checkpoints kept (0: all).
        save_final: write ``final.pt`` when the run reaches its last iteration.
    """

    name = "checkpointer"

    def __init__(
        self, directory: str | os.PathLike[str], every: int = 0, keep_last: int = 0, save_final: bool = True
    ) -> None:
        if int(every) < 0 or int(keep_last) < 0:
            raise ValueError(f"checkpoint.every and checkpoint.keep_last must be >= 0; got {every}, {keep_last}")
        self.directory = Path(directory)
        self.every = int(every)
        self.keep_last = int(keep_last)
        self.save_final = bool(save_final)
        self._ran = False
        self.last_path: Path | None = None

    def save(self, trainer: Any, name: str) -> Path:
        """``trainer.save(directory / name)``, then point ``last.pt`` at it and prune old checkpoints."""
        path = trainer.save(self.directory / name)
        last = path.parent / "last.pt"
        tmp = path.parent / f".last.{os.getpid()}.tmp"
        try:
            tmp.unlink(missing_ok=True)
            os.link(path, tmp)
            os.replace(tmp, last)
        except OSError:
            trainer.save(last)
        if self.keep_last > 0:
            for old in sorted(path.parent.glob("ckpt_*.pt"))[: -self.keep_last]:
                old.unlink(missing_ok=True)
        self.last_path = path
        return path

    def on_train_start(self, trainer: Any) -> None:
        self._ran = False

    def on_iteration_end(self, trainer: Any, metrics: dict[str, float]) -> None:
        self._ran = True
        if self.every and trainer.iteration % self.every == 0:
            self.save(trainer, f"ckpt_{trainer.iteration:06d}.pt")

    def on_train_end(self, trainer: Any, stopped: bool) -> None:
        if stopped:
            steps = trainer.rollout.steps_done
            suffix = f"_step{steps:04d}" if steps else ""
            path = self.save(trainer, f"ckpt_{trainer.iteration:06d}{suffix}.pt")
            where = f" and {steps} env steps of the next" if steps else ""
            print(f"stopped after iteration {trainer.iteration}{where}; checkpoint: {path}", flush=True)
        elif self.save_final and self._ran and trainer.iteration >= trainer.total_iterations:
            self.save(trainer, "final.pt")


__all__ = ["Checkpointer"]
