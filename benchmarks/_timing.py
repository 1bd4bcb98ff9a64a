"""Shared by the benchmark scripts (run as ``python benchmarks/<name>.py``, which puts this folder on ``sys.path``)."""

from __future__ import annotations

import torch


def sync(device: torch.device) -> None:
    """Wait for the device's queued work (CUDA); a no-op on the CPU, whose ops finish before they return."""
    if device.type == "cuda":
        torch.cuda.synchronize(device)
