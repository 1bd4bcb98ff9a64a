"""Progress display between and inside iterations."""

from __future__ import annotations

import math
import time
from typing import Any, TextIO

from ..progress import ProgressDisplay
from .base import TrainerHook


class ProgressHook(TrainerHook):
    """One line (or a tqdm bar) per iteration: frames, fps, mean success (and the KL when logged). Inside an
    iteration whose rollout takes long (a big CPU run), a line every ``inner_every_s`` seconds with the env step
    reached and the time left in the rollout.

    Args:
        mode: ``auto`` (tqdm on a terminal, else lines), ``tqdm``, ``line`` or ``none``.
        every: print period of the line mode (iterations).
        inner_every_s: seconds between in-iteration progress lines (0: never).
        stream: output stream (stdout).
    """

    name = "progress"

    def __init__(
        self, mode: str = "auto", every: int = 1, inner_every_s: float = 10.0, stream: TextIO | None = None
    ) -> None:
        self.mode, self.every, self.inner_every_s, self.stream = mode, int(every), float(inner_every_s), stream
        self.display: ProgressDisplay | None = None
        self._t0 = self._last = 0.0

    def on_train_start(self, trainer: Any) -> None:
        self.display = ProgressDisplay(trainer.total_iterations, mode=self.mode, every=self.every,
                                       initial=trainer.iteration, stream=self.stream)

    def on_iteration_start(self, trainer: Any) -> None:
        self._t0 = self._last = time.perf_counter()

    def on_rollout_step(self, trainer: Any, step: int, horizon: int) -> None:
        if self.display is None or self.inner_every_s <= 0 or self.display.mode == "none":
            return
        now = time.perf_counter()
        if now - self._last < self.inner_every_s:
            return
        self._last = now
        per_step = (now - self._t0) / step
        self.display.write(
            f"iteration {trainer.iteration + 1}/{trainer.total_iterations}: env step {step}/{horizon} "
            f"({per_step:.1f} s/step, rollout done in ~{math.ceil(per_step * (horizon - step))} s)"
        )

    def on_iteration_end(self, trainer: Any, metrics: dict[str, float]) -> None:
        if self.display is None:
            return
        extra = f"kl={metrics['train/kl']:.4f}" if "train/kl" in metrics else ""
        if "terrain_level/mean" in metrics:
            level = metrics["terrain_level/mean"]
            extra = f"level={'n/a' if math.isnan(level) else f'{level:.2f}'} {extra}".strip()
        metric = getattr(getattr(trainer, "window", None), "metric", "success")
        self.display.update(trainer.iteration, trainer.frames, metrics["fps"], metrics["success/mean"], extra, metric)

    def on_train_end(self, trainer: Any, stopped: bool) -> None:
        if self.display is not None:
            self.display.close()
            self.display = None

    def on_error(self, trainer: Any, error: BaseException) -> None:
        self.on_train_end(trainer, stopped=False)


__all__ = ["ProgressHook"]
