"""Checkpoint files (atomic, SHA-256 checksummed) and RNG state capture/restore."""

from __future__ import annotations

import hashlib
import io
import os
import random
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import torch

CHECKPOINT_VERSION = 2
MAGIC = b"MTBENCH-CHECKPOINT\n"
_HEADER_LEN = len(b"sha256=") + 64 + len(b" size=") + 20 + 1  # fixed-width header line after MAGIC


class CheckpointError(ValueError):
    """A checkpoint file that cannot be used: ``str(err)`` names the file, ``err.reason`` says why."""

    def __init__(self, path: str | os.PathLike[str], reason: str) -> None:
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"checkpoint {self.path}: {reason}")


def _header(payload: bytes) -> bytes:
    return f"sha256={hashlib.sha256(payload).hexdigest()} size={len(payload):020d}\n".encode()


def save_checkpoint(path: str | os.PathLike[str], state: dict[str, Any]) -> Path:
    """Write ``state`` (``torch.save`` payload) behind a header holding its SHA-256 and size, to a temporary
    file in the target directory, fsync it, then ``os.replace`` it onto ``path`` (a crash never leaves a
    truncated checkpoint behind; a later corruption is detected by :func:`load_checkpoint`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    torch.save(state, buffer)
    payload = buffer.getbuffer()
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(MAGIC)
            f.write(_header(payload))
            f.write(payload)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    try:  # make the rename durable
        dir_fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
    except OSError:
        pass
    return path


def read_checkpoint_payload(path: str | os.PathLike[str]) -> bytes:
    """The verified ``torch.save`` payload of a checkpoint file; raises :class:`CheckpointError` for a
    directory, a missing file, a file that is not an mtbench checkpoint, a truncated or corrupted file."""
    path = Path(path)
    if path.is_dir():
        raise CheckpointError(path, "is a directory; give a checkpoint file written by mtbench (e.g. "
                                    f"{path / 'checkpoints' / 'last.pt'} or {path / 'last.pt'})")
    if not path.is_file():
        raise CheckpointError(path, "no such file")
    data = path.read_bytes()
    if not data.startswith(MAGIC):
        raise CheckpointError(path, "not an mtbench checkpoint (the file does not start with the mtbench "
                                    "checkpoint header)")
    header = data[len(MAGIC) : len(MAGIC) + _HEADER_LEN]
    payload = data[len(MAGIC) + _HEADER_LEN :]
    try:
        fields = dict(item.split("=", 1) for item in header.decode("ascii").split())
        digest, size = fields["sha256"], int(fields["size"])
    except (UnicodeDecodeError, ValueError, KeyError):
        raise CheckpointError(path, "damaged checkpoint header") from None
    if len(payload) != size:
        raise CheckpointError(path, f"truncated or extended file: payload of {len(payload)} bytes, the header says "
                                    f"{size}")
    actual = hashlib.sha256(payload).hexdigest()
    if actual != digest:
        raise CheckpointError(path, f"checksum mismatch, the file is corrupted (SHA-256 {actual}, expected {digest}); "
                                    "resume from another checkpoint (e.g. an older ckpt_*.pt)")
    return payload


def load_checkpoint(path: str | os.PathLike[str], map_location: str | torch.device = "cpu") -> dict[str, Any]:
    """Load a checkpoint written by :func:`save_checkpoint` (checksum and format version verified)."""
    payload = read_checkpoint_payload(path)
    state = torch.load(io.BytesIO(payload), map_location=map_location, weights_only=False)
    version = state.get("version") if isinstance(state, dict) else None
    if version != CHECKPOINT_VERSION:
        raise CheckpointError(path, f"unsupported checkpoint version {version!r} (expected {CHECKPOINT_VERSION})")
    return state


def rng_state() -> dict[str, Any]:
    """Python, NumPy, torch CPU and (if initialised) all CUDA generator states."""
    state: dict[str, Any] = {
        "python": random.getstate(),
        "numpy": np.random.get_state(),
        "torch": torch.get_rng_state(),
    }
    if torch.cuda.is_available() and torch.cuda.is_initialized():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def set_rng_state(state: dict[str, Any]) -> None:
    """Restore the generator states captured by :func:`rng_state`."""
    random.setstate(state["python"])
    np.random.set_state(state["numpy"])
    torch.set_rng_state(state["torch"])
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(state["cuda"])


def seed_everything(seed: int) -> None:
    """Seed Python, NumPy and torch (all devices)."""
    random.seed(seed)
    np.random.seed(seed % (2**32))
    torch.manual_seed(seed)


__all__ = [
    "CHECKPOINT_VERSION",
    "CheckpointError",
    "load_checkpoint",
    "read_checkpoint_payload",
    "rng_state",
    "save_checkpoint",
    "seed_everything",
    "set_rng_state",
]
