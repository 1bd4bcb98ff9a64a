"""Graceful stop on SIGINT / SIGTERM (finish the current env step, checkpoint, exit) and on SIGUSR1 (finish the
current iteration, checkpoint, exit)."""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType, TracebackType
from typing import Any, TextIO


#: the signal that asks for a stop at the end of the current iteration (POSIX only)
ITERATION_END_SIGNAL: int | None = getattr(signal, "SIGUSR1", None)


class StopRequest:
    """While active (``with StopRequest() as stop:``), the first SIGINT (Ctrl-C) or SIGTERM sets
    ``stop.requested`` and prints what happens next; the training loop checks it after every env step (a step
    of all worlds) and after every update, then writes a checkpoint and returns. A second SIGINT raises
    ``KeyboardInterrupt`` at once.

    SIGUSR1 (``ITERATION_END_SIGNAL``) asks for the same stop at the end of the current iteration instead
    (``stop.at_iteration_end``): the rollout runs to its end and the update follows, so the checkpoint holds no
    partial rollout (a partial one is the largest part of a checkpoint: ~500 MB for 25 steps of MT50's 24,576
    worlds). A SIGINT or SIGTERM after it still stops after the current env step.

    ``stop()`` is what the rollout asks after every env step: true for a stop after the env step. Outside the main
    thread (where signal handlers cannot be installed) it only holds the flag (``request()`` sets it)."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.requested = False
        self.at_iteration_end = False
        self.signum: int | None = None
        self.stream = stream
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            signals = [signal.SIGINT, signal.SIGTERM]
            if ITERATION_END_SIGNAL is not None:
                signals.append(ITERATION_END_SIGNAL)
            for sig in signals:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def rearm(self) -> list[str]:
        """Install the handlers again and unblock their signals in the main thread; returns what was found changed
        (and says so on the stream). The trainer calls it between iterations: a library that takes over a signal
        while the run builds or compiles something -- in C, where ``signal.getsignal`` cannot see it, or by blocking
        the signal -- would otherwise leave the run deaf to it (seen on an H200: SIGUSR1 ignored by runs whose first
        iteration compiled kernels afresh). Does nothing outside an active ``with`` block or the main thread."""
        if not self._previous or threading.current_thread() is not threading.main_thread():
            return []
        changed = []
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, []) if hasattr(signal, "pthread_sigmask") else set()
        for sig in self._previous:
            name = signal.Signals(sig).name
            handler = signal.getsignal(sig)
            if handler != self._handle:
                changed.append(f"{name} handler was {handler!r}")
            if sig in blocked:
                changed.append(f"{name} was blocked")
                signal.pthread_sigmask(signal.SIG_UNBLOCK, [sig])
            signal.signal(sig, self._handle)  # also replaces a handler installed in C, invisible to getsignal
        if changed:
            print(f"stop signals re-armed ({'; '.join(changed)})", file=self.stream or sys.stderr, flush=True)
        return changed

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.restore()

    def __call__(self) -> bool:
        return self.requested and not self.at_iteration_end

    def request(self, signum: int | None = None, at_iteration_end: bool = False) -> None:
        """Ask the loop to stop (what the signal handler does): after the current env step, or with
        ``at_iteration_end`` at the end of the current iteration (unless a stop after the env step is pending)."""
        self.at_iteration_end = at_iteration_end and (self.at_iteration_end or not self.requested)
        self.requested, self.signum = True, signum

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.requested and not self.at_iteration_end and signum == signal.SIGINT:
            raise KeyboardInterrupt
        at_end = signum == ITERATION_END_SIGNAL
        self.request(signum, at_iteration_end=at_end)
        name = signal.Signals(signum).name
        if at_end:
            what = ("at the end of the current iteration and writing a checkpoint; SIGTERM or Ctrl-C stops after "
                    "the current env step instead")
        else:
            what = ("after the current env step (or, during an update, after it) and writing a checkpoint; press "
                    "Ctrl-C again to abort without one")
        print(f"\n{name}: stopping {what}", file=self.stream or sys.stderr, flush=True)

    def restore(self) -> None:
        """Put the previous signal handlers back."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()


__all__ = ["StopRequest"]
