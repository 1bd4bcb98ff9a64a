"""Progress display: a tqdm bar on a terminal, a clean single-line printer otherwise."""

from __future__ import annotations

import math
import sys
from typing import Any, TextIO

_MODES = ("auto", "tqdm", "line", "none")


def _fmt_success(value: float) -> str:
    return "n/a" if value is None or math.isnan(value) else f"{100 * value:5.1f}%"


class ProgressDisplay:
    """Shows ``iteration, frames, fps, mean success`` once per iteration.

    Args:
        total_iterations: number of iterations of the run.
        mode: ``"tqdm"`` (progress bar), ``"line"`` (one line per ``every`` iterations, log friendly),
            ``"none"``, or ``"auto"`` (tqdm when stdout is a terminal, else line).
        every: print period of the line printer.
        initial: iteration to start from (resume).
        stream: output stream (stdout).
    """

    def __init__(
        self,
        total_iterations: int,
        mode: str = "auto",
        every: int = 1,
        initial: int = 0,
        stream: TextIO | None = None,
    ) -> None:
        if mode not in _MODES:
            raise ValueError(f"unknown progress mode {mode!r}; valid choices: {list(_MODES)}")
        self.stream = stream or sys.stdout
        if mode == "auto":
            mode = "tqdm" if getattr(self.stream, "isatty", lambda: False)() else "line"
        self.mode = mode
        self.every = max(1, int(every))
        self.total = int(total_iterations)
        self._bar: Any = None
        if mode == "tqdm":
            from tqdm.auto import tqdm

            self._bar = tqdm(total=self.total, initial=initial, file=self.stream, dynamic_ncols=True, unit="it")

    def update(self, iteration: int, frames: int, fps: float, success: float, extra: str = "",
               metric: str = "success") -> None:
        """Report the state after ``iteration`` (1-based) iterations; ``metric`` names the mean of ``success``
        (Parkour: ``progress``)."""
        if self.mode == "none":
            return
        if self._bar is not None:
            self._bar.update(iteration - self._bar.n)
            self._bar.set_postfix_str(f"frames={frames:,} fps={fps:,.0f} {metric}={_fmt_success(success)} {extra}".strip())
            return
        if iteration % self.every == 0 or iteration == self.total:
            width = len(str(self.total))
            line = (
                f"[iter {iteration:>{width}}/{self.total}] frames={frames:,} fps={fps:,.0f} "
                f"{metric}={_fmt_success(success)}"
            )
            if extra:
                line += f" {extra}"
            print(line, file=self.stream, flush=True)

    def write(self, text: str) -> None:
        """Print a message without breaking the bar."""
        if self._bar is not None:
            self._bar.write(text, file=self.stream)
        else:
            print(text, file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
