"""Readers for the MCAP files written by :class:`mtbench.logging.MCAPLogger`.

The readers scan files linearly with the ``mcap`` package's ``StreamReader`` and stop quietly (with a
:class:`TruncatedMCAPWarning`) at the first incomplete record, so a file of a killed or still-running process
is readable up to its last flushed chunk. No torch import.
"""

from __future__ import annotations

import contextlib
import json
import struct
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from mcap.exceptions import EndOfFile, McapError
from mcap.records import Channel, Header, Message, Metadata
from mcap.stream_reader import StreamReader

from mtbench.logging.schemas import (
    METADATA_NAME,
    TOPIC_HISTOGRAMS,
    TOPIC_HPARAMS,
    TOPIC_SCALARS,
    decode_float,
    parse_segment_filename,
)

__all__ = [
    "TruncatedMCAPWarning",
    "find_segments",
    "iter_messages",
    "read_histograms",
    "read_hparams",
    "read_run_metadata",
    "read_scalars",
]

PathLike = str | Path


class TruncatedMCAPWarning(UserWarning):
    """The file has no footer (process killed, or still writing): data was read up to the last complete record."""


def _corruption_errors() -> tuple[type[BaseException], ...]:
    errors: list[type[BaseException]] = [McapError, struct.error, EOFError, ValueError, RuntimeError]
    try:
        import zstandard

        errors.append(zstandard.ZstdError)
    except ImportError:  # pragma: no cover - zstandard is a dependency of mcap
        pass
    return tuple(errors)


_CORRUPTION_ERRORS = _corruption_errors()


def _iter_records(path: Path, *, emit_chunks: bool = False) -> Iterator[Any]:
    """All records of ``path`` in file order (chunks expanded unless ``emit_chunks``), tolerant to truncation."""
    with open(path, "rb") as stream:
        records = StreamReader(stream, emit_chunks=emit_chunks).records
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except _CORRUPTION_ERRORS as err:
                if stream.tell() <= 8:
                    raise ValueError(f"{path}: not a readable MCAP file ({type(err).__name__}: {err})") from err
                if isinstance(err, EndOfFile):
                    reason = "no MCAP footer: the writer was killed or is still running"
                else:
                    reason = f"damaged near byte {stream.tell()} ({type(err).__name__}: {err})"
                warnings.warn(
                    f"{path}: {reason}; using the data up to the last complete chunk",
                    TruncatedMCAPWarning,
                    stacklevel=3,
                )
                return
            yield record


def iter_messages(path: PathLike, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int, Any]]:
    """Decoded messages of one MCAP file, in file order: ``(topic, log_time_ns, json_payload)``.

    Only JSON-encoded channels are decoded (all channels written by ``MCAPLogger`` are).
    ``topics`` filters by exact topic name; names starting with a prefix can be selected by the caller.
    """
    path = Path(path)
    wanted = None if topics is None else set(topics)
    channels: dict[int, Channel] = {}
    for record in _iter_records(path):
        if isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message):
            channel = channels.get(record.channel_id)
            if channel is None:
                raise ValueError(f"{path}: message on unknown channel id {record.channel_id}")
            if channel.message_encoding != "json":
                continue
            if wanted is not None and channel.topic not in wanted:
                continue
            try:
                payload = json.loads(record.data)
            except ValueError as err:  # JSONDecodeError, UnicodeDecodeError
                raise ValueError(
                    f"{path}: damaged MCAP file: a message on {channel.topic} is not valid JSON ({err})"
                ) from err
            yield channel.topic, record.log_time, payload


def read_run_metadata(path: PathLike) -> dict[str, str] | None:
    """The ``mtbench.run`` metadata record of one file (``exp_name``, ``segment``, ...), or ``None``."""
    with contextlib.closing(_iter_records(Path(path), emit_chunks=True)) as records:
        for record in records:
            if isinstance(record, Header):
                continue
            if isinstance(record, Metadata) and record.name == METADATA_NAME:
                return dict(record.metadata)
            # MCAPLogger writes its metadata right after the header: anything else means it has none.
            return None
    return None


def _segment_identity(path: Path) -> tuple[str, int]:
    meta = read_run_metadata(path)
    if meta is not None and "exp_name" in meta and "segment" in meta:
        return meta["exp_name"], int(meta["segment"])
    return parse_segment_filename(path)


def find_segments(path_or_dir: PathLike, *, all_segments: bool = True) -> list[Path]:
    """The segment files of one experiment, in segment order.

    Args:
        path_or_dir: one ``.mcap`` file (its sibling segments ``<exp>.<k>.mcap`` are included when
            ``all_segments``) or a directory holding the segments of exactly one experiment.
        all_segments: if False and a file is given, return only that file.
    """
    path = Path(path_or_dir)
    if path.is_dir():
        groups: dict[str, list[tuple[int, Path]]] = {}
        for candidate in sorted(path.glob("*.mcap")):
            exp, segment = _segment_identity(candidate)
            groups.setdefault(exp, []).append((segment, candidate))
        if not groups:
            raise FileNotFoundError(f"{path}: no .mcap files in this directory")
        if len(groups) > 1:
            raise ValueError(
                f"{path} holds several experiments ({', '.join(sorted(groups))}); pass the path of one .mcap file"
            )
        (segments,) = groups.values()
        return [p for _, p in sorted(segments)]
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file or directory")
    if not all_segments:
        return [path]
    exp, _ = _segment_identity(path)
    found: list[tuple[int, Path]] = []
    for candidate in sorted(path.parent.glob("*.mcap")):
        try:
            guess, _ = parse_segment_filename(candidate)
        except ValueError:
            continue
        if guess != exp and candidate.name != f"{exp}.mcap":
            continue
        cand_exp, cand_segment = _segment_identity(candidate)
        if cand_exp == exp:
            found.append((cand_segment, candidate))
    if not any(p.resolve() == path.resolve() for _, p in found):  # e.g. file renamed by the user
        found.append((_segment_identity(path)[1], path))
    return [p for _, p in sorted(found, key=lambda item: (item[0], item[1].name))]


def read_scalars(path_or_dir: PathLike, *, all_segments: bool = True) -> dict[str, list[tuple[int, float]]]:
    """All scalars of a run: ``{name: [(step, value), ...]}`` sorted by step.

    Segments (``<exp>.mcap``, ``<exp>.1.mcap``, ...) are merged in segment order. A later segment replaces,
    for each name, the points of earlier segments whose step is >= the first step it logged for that name:
    after a resume from a checkpoint, the points logged by the dead process past the checkpoint are dropped.
    Non-finite values come back as ``nan``/``inf``.
    """
    merged: dict[str, list[tuple[int, float]]] = {}
    for file in find_segments(path_or_dir, all_segments=all_segments):
        segment: dict[str, list[tuple[int, float]]] = {}
        for _, _, msg in iter_messages(file, topics=[TOPIC_SCALARS]):
            value = decode_float(msg["value"], msg.get("nonfinite"))
            segment.setdefault(msg["name"], []).append((int(msg["step"]), value))
        for name, points in segment.items():
            points.sort(key=lambda p: p[0])
            first = points[0][0]
            kept = [p for p in merged.get(name, []) if p[0] < first]
            merged[name] = kept + points
    return dict(sorted(merged.items()))


def read_hparams(path_or_dir: PathLike, *, all_segments: bool = True) -> dict[str, Any]:
    """The flattened hyperparameters of a run (later messages/segments override earlier keys)."""
    hparams: dict[str, Any] = {}
    for file in find_segments(path_or_dir, all_segments=all_segments):
        for _, _, msg in iter_messages(file, topics=[TOPIC_HPARAMS]):
            hparams.update(msg["hparams"])
    return hparams


def read_histograms(path_or_dir: PathLike, *, all_segments: bool = True) -> dict[str, list[dict[str, Any]]]:
    """All histograms of a run: ``{name: [message, ...]}`` (message fields: see ``mtbench.Histogram``)."""
    out: dict[str, list[dict[str, Any]]] = {}
    for file in find_segments(path_or_dir, all_segments=all_segments):
        for _, _, msg in iter_messages(file, topics=[TOPIC_HISTOGRAMS]):
            out.setdefault(msg["name"], []).append(msg)
    for msgs in out.values():
        msgs.sort(key=lambda m: m["step"])
    return out
