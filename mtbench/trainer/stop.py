"""Graceful stop on SIGINT / SIGTERM: finish the current env step, checkpoint, exit."""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType, TracebackType
from typing import Any, TextIO


class StopRequest:
    """While active (``with StopRequest() as stop:``), the first SIGINT (Ctrl-C) or SIGTERM sets
    ``stop.requested`` and prints what happens next; the training loop checks it after every env step (a step
    of all worlds) and after every update, then writes a checkpoint and returns. A second SIGINT raises
    ``KeyboardInterrupt`` at once. Outside the main thread (where signal handlers cannot be installed) it only
    holds the flag (``request()`` sets it)."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.requested = False
        self.signum: int | None = None
        self.stream = stream
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.restore()

    def __call__(self) -> bool:
        return self.requested

    def request(self, signum: int | None = None) -> None:
        """Ask the loop to stop (what the signal handler does)."""
        self.requested, self.signum = True, signum

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.requested and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.request(signum)
        name = signal.Signals(signum).name
        print(f"\n{name}: stopping after the current env step (or, during an update, after it) and writing a "
              "checkpoint; press Ctrl-C again to abort without one", file=self.stream or sys.stderr, flush=True)

    def restore(self) -> None:
        """Put the previous signal handlers back."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()


__all__ = ["StopRequest"]
