"""MCAP metric logging: :class:`MCAPLogger` (a torchrl ``Logger``) and torch-free readers.

``MCAPLogger`` is imported lazily so that the readers (and ``python -m mtbench.logs``) do not import
torch/torchrl. See ``docs/logging.md``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mtbench.logging.reader import (
    TruncatedMCAPWarning,
    find_segments,
    iter_messages,
    read_histograms,
    read_hparams,
    read_run_metadata,
    read_scalars,
)

if TYPE_CHECKING:
    from mtbench.logging.mcap_logger import MCAPLogger

__all__ = [
    "MCAPLogger",
    "TruncatedMCAPWarning",
    "find_segments",
    "iter_messages",
    "read_histograms",
    "read_hparams",
    "read_run_metadata",
    "read_scalars",
]


def __getattr__(name: str) -> Any:
    if name == "MCAPLogger":
        from mtbench.logging.mcap_logger import MCAPLogger

        return MCAPLogger
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
