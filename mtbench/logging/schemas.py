"""MCAP layout shared by the writer (:mod:`mtbench.logging.mcap_logger`) and the readers.

Every message is JSON (``message_encoding="json"``) and every channel has a JSON-Schema schema
(``schema encoding="jsonschema"``), so generic MCAP tools (``mcap`` CLI, Foxglove) can decode them.
See ``docs/logging.md`` for the full description.

This module imports neither torch nor torchrl: the readers and the ``python -m mtbench.logs`` CLI stay light.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

FORMAT_VERSION = "1"
"""Version of the mtbench MCAP layout, stored in the ``mtbench.run`` metadata record."""

METADATA_NAME = "mtbench.run"
"""Name of the MCAP metadata record written right after the header of every segment."""

TOPIC_SCALARS = "/scalars"
TOPIC_HPARAMS = "/hparams"
TOPIC_HISTOGRAMS = "/histograms"
VIDEO_TOPIC_PREFIX = "/video/"

SCHEMA_SCALAR = "mtbench.Scalar"
SCHEMA_HPARAMS = "mtbench.HParams"
SCHEMA_HISTOGRAM = "mtbench.Histogram"
SCHEMA_IMAGE = "foxglove.CompressedImage"

_NULLABLE_NUMBER: dict[str, Any] = {"type": ["number", "null"]}

JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    SCHEMA_SCALAR: {
        "title": SCHEMA_SCALAR,
        "description": "One scalar value (one per log_scalar call and per entry of a log_metrics call).",
        "type": "object",
        "properties": {
            "step": {"type": "integer", "description": "Training step given by the caller."},
            "name": {"type": "string", "description": "Metric name, e.g. 'loss/critic' or 'success/reach-v3'."},
            "value": {
                "type": ["number", "null"],
                "description": "The value; null when it is not finite (see 'nonfinite').",
            },
            "nonfinite": {
                "type": "string",
                "enum": ["nan", "inf", "-inf"],
                "description": "Present only when the value is not finite.",
            },
            "wall_time": {"type": "number", "description": "Unix time in seconds when the value was logged."},
        },
        "required": ["step", "name", "value", "wall_time"],
    },
    SCHEMA_HPARAMS: {
        "title": SCHEMA_HPARAMS,
        "description": "Hyperparameters, flattened with '.'-joined keys.",
        "type": "object",
        "properties": {
            "wall_time": {"type": "number", "description": "Unix time in seconds."},
            "hparams": {
                "type": "object",
                "description": "Flat mapping 'a.b.c' -> JSON value (numbers, strings, booleans, null, lists).",
                "additionalProperties": True,
            },
        },
        "required": ["wall_time", "hparams"],
    },
    SCHEMA_HISTOGRAM: {
        "title": SCHEMA_HISTOGRAM,
        "description": "Histogram of the finite values of a tensor (one per log_histogram call).",
        "type": "object",
        "properties": {
            "step": {"type": "integer"},
            "name": {"type": "string"},
            "wall_time": {"type": "number", "description": "Unix time in seconds."},
            "bin_edges": {"type": "array", "items": {"type": "number"}, "description": "len(counts) + 1 edges."},
            "counts": {"type": "array", "items": {"type": "integer"}},
            "count": {"type": "integer", "description": "Number of finite values."},
            "nonfinite_count": {"type": "integer", "description": "Number of NaN/inf values (not binned)."},
            "min": _NULLABLE_NUMBER,
            "max": _NULLABLE_NUMBER,
            "mean": _NULLABLE_NUMBER,
            "std": _NULLABLE_NUMBER,
        },
        "required": ["step", "name", "wall_time", "bin_edges", "counts", "count", "nonfinite_count"],
    },
    # Foxglove's well-known image schema (JSON flavour: bytes are base64 strings), plus two
    # mtbench fields (step, frame_index) that Foxglove ignores.
    SCHEMA_IMAGE: {
        "title": SCHEMA_IMAGE,
        "description": "A compressed image (one video frame, PNG).",
        "type": "object",
        "properties": {
            "timestamp": {
                "type": "object",
                "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
                "required": ["sec", "nsec"],
            },
            "frame_id": {"type": "string"},
            "data": {"type": "string", "contentEncoding": "base64"},
            "format": {"type": "string", "description": "Always 'png'."},
            "step": {"type": "integer", "description": "mtbench: step passed to log_video."},
            "frame_index": {"type": "integer", "description": "mtbench: index of the frame in the video."},
        },
        "required": ["timestamp", "frame_id", "data", "format"],
    },
}


def schema_bytes(schema_name: str) -> bytes:
    """The JSON-Schema document of ``schema_name`` as the bytes stored in the MCAP Schema record."""
    return json.dumps(JSON_SCHEMAS[schema_name], separators=(",", ":"), sort_keys=True).encode()


def encode_float(value: float) -> tuple[float | None, str | None]:
    """Split a float into its JSON value (``None`` when not finite) and the ``nonfinite`` tag."""
    if math.isfinite(value):
        return value, None
    if math.isnan(value):
        return None, "nan"
    return None, ("inf" if value > 0 else "-inf")


def decode_float(value: float | int | None, nonfinite: str | None = None) -> float:
    """Inverse of :func:`encode_float`."""
    if nonfinite is not None:
        return {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}[nonfinite]
    if value is None:
        return math.nan
    return float(value)


def json_dumps(obj: Any) -> bytes:
    """Compact, strictly standard JSON (``NaN``/``Infinity`` are rejected: encode them first)."""
    return json.dumps(obj, separators=(",", ":"), allow_nan=False).encode()


_SEGMENT_RE = re.compile(r"^(?P<exp>.+)\.(?P<k>\d+)\.mcap$")


def segment_path(log_dir: str | Path, exp_name: str, segment: int) -> Path:
    """File of segment ``segment`` of experiment ``exp_name``: ``<exp>.mcap`` for 0, ``<exp>.<k>.mcap`` after."""
    name = f"{exp_name}.mcap" if segment == 0 else f"{exp_name}.{segment}.mcap"
    return Path(log_dir) / name


def parse_segment_filename(path: str | Path) -> tuple[str, int]:
    """``(exp_name, segment)`` guessed from a file name (used when a file has no metadata record).

    ``run.mcap`` -> ``("run", 0)``; ``run.3.mcap`` -> ``("run", 3)``.
    """
    name = Path(path).name
    match = _SEGMENT_RE.match(name)
    if match is not None:
        return match.group("exp"), int(match.group("k"))
    if not name.endswith(".mcap"):
        raise ValueError(f"{path}: not an .mcap file")
    return name[: -len(".mcap")], 0
