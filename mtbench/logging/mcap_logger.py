"""``MCAPLogger``: a torchrl :class:`~torchrl.record.loggers.Logger` writing metrics to an MCAP file.

Layout (see ``docs/logging.md``): JSON messages with JSON-Schema schemas on ``/scalars`` (one message per
scalar value), ``/hparams`` (flattened hyperparameters), ``/histograms`` and ``/video/<name>``
(``foxglove.CompressedImage`` PNG frames). A metadata record ``mtbench.run`` (``exp_name``, ``segment``, ...)
follows the header.

Durability: messages are buffered in the current MCAP chunk; a background thread finalizes the chunk and
flushes the file every ``flush_interval_s`` seconds when something was logged, so a killed process loses at
most that much. ``close()`` (also run from ``atexit`` and ``__del__``) writes the summary and footer. MCAP
files cannot be appended to once finished: a resumed run (``if_exists="append"``) writes a new segment file
``<exp_name>.<k>.mcap`` next to ``<exp_name>.mcap``; the readers merge segments.
"""

from __future__ import annotations

import atexit
import base64
import dataclasses
import enum
import functools
import io
import logging
import math
import os
import socket
import threading
import time
import weakref
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType, Writer
from tensordict import TensorDictBase
from torchrl.record.loggers import Logger

import mtbench
from mtbench.logging.reader import read_run_metadata
from mtbench.logging.schemas import (
    FORMAT_VERSION,
    METADATA_NAME,
    SCHEMA_HISTOGRAM,
    SCHEMA_HPARAMS,
    SCHEMA_IMAGE,
    SCHEMA_SCALAR,
    TOPIC_HISTOGRAMS,
    TOPIC_HPARAMS,
    TOPIC_SCALARS,
    VIDEO_TOPIC_PREFIX,
    encode_float,
    json_dumps,
    parse_segment_filename,
    schema_bytes,
    segment_path,
)

__all__ = ["MCAPLogger", "flatten_hparams"]

_log = logging.getLogger(__name__)

_COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}
_IF_EXISTS = ("error", "append", "overwrite")
_VIDEO_MODES = ("png", "skip")


# ----------------------------------------------------------------------------------------------------------------
# The open file ("experiment")
# ----------------------------------------------------------------------------------------------------------------
class MCAPRun:
    """One open MCAP segment file: lazily registered schemas/channels, thread-safe writes, periodic flush.

    This is :attr:`MCAPLogger.experiment`. Writes are only allowed from the process that created it: a forked
    child that inherits it never writes to (nor finalizes) the parent's file.
    """

    def __init__(
        self,
        path: Path,
        *,
        metadata: dict[str, str],
        compression: str,
        chunk_size: int,
        flush_interval_s: float | None,
    ) -> None:
        self.path = path
        self._pid = os.getpid()
        self._lock = threading.RLock()
        self._closed = False
        self._dirty = False
        self._schema_ids: dict[str, int] = {}
        self._channel_ids: dict[str, int] = {}
        self._sequence: dict[int, int] = {}
        self._file = open(path, "wb")  # noqa: SIM115 - closed in close()
        try:
            self._writer = Writer(self._file, chunk_size=chunk_size, compression=_COMPRESSIONS[_available(compression)])
            if not hasattr(self._writer, "flush"):
                raise ImportError("MCAPLogger needs mcap>=1.6 (Writer.flush); upgrade the 'mcap' package")
            self._writer.start(profile="", library=f"mtbench/{mtbench.__version__}; {LIBRARY_IDENTIFIER}")
            self._writer.add_metadata(METADATA_NAME, metadata)
            self._writer.flush()
        except BaseException:
            self._closed = True
            self._file.close()
            raise
        self._atexit_hook = functools.partial(_close_if_alive, weakref.ref(self))
        atexit.register(self._atexit_hook)
        os.register_at_fork(
            before=functools.partial(_before_fork, weakref.ref(self)),
            after_in_parent=functools.partial(_after_fork, weakref.ref(self)),
            after_in_child=functools.partial(_after_fork, weakref.ref(self)),
        )
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if flush_interval_s is not None:
            self._thread = threading.Thread(
                target=_flush_loop,
                args=(weakref.ref(self), self._stop, float(flush_interval_s)),
                name=f"MCAPLogger-flush-{path.name}",
                daemon=True,
            )
            self._thread.start()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` ran."""
        return self._closed

    @property
    def has_messages(self) -> bool:
        """Whether anything but the metadata record was written (a channel exists)."""
        return bool(self._channel_ids)

    def _channel(self, topic: str, schema_name: str) -> int:
        channel_id = self._channel_ids.get(topic)
        if channel_id is None:
            schema_id = self._schema_ids.get(schema_name)
            if schema_id is None:
                schema_id = self._writer.register_schema(
                    name=schema_name, encoding="jsonschema", data=schema_bytes(schema_name)
                )
                self._schema_ids[schema_name] = schema_id
            channel_id = self._writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_id)
            self._channel_ids[topic] = channel_id
            self._sequence[channel_id] = 0
        return channel_id

    def write(self, topic: str, schema_name: str, payloads: Sequence[tuple[int, dict[str, Any]]]) -> None:
        """Append messages ``(log_time_ns, json_payload)`` to ``topic`` (schema ``schema_name``)."""
        if os.getpid() != self._pid:
            raise RuntimeError(
                f"MCAPLogger for {self.path} was created in process {self._pid}; it cannot write from process "
                f"{os.getpid()} (forked child). Create a logger in the child or log from the parent."
            )
        encoded = [(log_time, json_dumps(payload)) for log_time, payload in payloads]
        with self._lock:
            if self._closed:
                raise RuntimeError(f"MCAPLogger for {self.path} is closed")
            channel_id = self._channel(topic, schema_name)
            for log_time, data in encoded:
                seq = self._sequence[channel_id]
                self._sequence[channel_id] = seq + 1
                self._writer.add_message(
                    channel_id=channel_id, log_time=log_time, data=data, publish_time=log_time, sequence=seq
                )
            self._dirty = True

    def flush(self, *, only_if_dirty: bool = False) -> None:
        """Finalize the current chunk and flush the file to the OS (readable by a concurrent reader)."""
        if os.getpid() != self._pid:
            return
        with self._lock:
            if self._closed or (only_if_dirty and not self._dirty):
                return
            self._writer.flush()
            self._dirty = False

    def close(self) -> None:
        """Write the summary section and footer, then close the file. Idempotent."""
        if os.getpid() != self._pid or getattr(self, "_closed", True):
            return
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._stop.set()
            try:
                self._writer.finish()
            finally:
                self._file.close()
                atexit.unregister(self._atexit_hook)

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - never raise from a finalizer
            pass

    def __repr__(self) -> str:
        return f"MCAPRun(path={str(self.path)!r}, closed={self._closed})"


def _close_if_alive(ref: weakref.ref[MCAPRun]) -> None:
    run = ref()
    if run is not None:
        run.close()


def _before_fork(ref: weakref.ref[MCAPRun]) -> None:
    # Empty the Python-side file buffer and hold the lock across fork: the child then inherits no pending bytes
    # (which it would otherwise write into the parent's file when it finalizes its copy) and no locked lock.
    run = ref()
    if run is not None and os.getpid() == run._pid:
        run._lock.acquire()
        if not run._closed:
            run._file.flush()


def _after_fork(ref: weakref.ref[MCAPRun]) -> None:
    run = ref()
    if run is not None and run._lock._is_owned():  # type: ignore[attr-defined]
        run._lock.release()


def _flush_loop(ref: weakref.ref[MCAPRun], stop: threading.Event, interval: float) -> None:
    while not stop.wait(interval):
        run = ref()
        if run is None:
            return
        try:
            run.flush(only_if_dirty=True)
        except Exception as err:  # noqa: BLE001 - report and stop flushing, the writer keeps working
            _log.warning("MCAPLogger: periodic flush of %s failed (%s); periodic flushing stops", run.path, err)
            return
        del run


# ----------------------------------------------------------------------------------------------------------------
# Value conversion
# ----------------------------------------------------------------------------------------------------------------
def _flatten_metric_mapping(metrics: Mapping[str, Any], sep: str, prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            out.update(_flatten_metric_mapping(value, sep, prefix=f"{name}{sep}"))
        else:
            out[name] = value
    return out


def _python_scalar(name: str, value: Any) -> float | int:
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, np.generic) and value.size == 1:
        return value.item()
    if isinstance(value, np.ndarray) and value.size == 1:
        return value.item()
    if isinstance(value, torch.Tensor):
        if value.numel() != 1:
            raise ValueError(
                f"metric {name!r} has shape {tuple(value.shape)}: only single-element values can be logged "
                "(log one scalar per entry, e.g. 'success/<task>')"
            )
        return value.item()
    raise TypeError(f"metric {name!r}: expected a number or a single-element tensor, got {type(value).__name__}")


def metrics_to_host(metrics: Mapping[str, Any] | TensorDictBase, *, keys_sep: str = "/") -> dict[str, float | int]:
    """Convert metric values to Python numbers with at most one device sync per device.

    Nested mappings / TensorDicts are flattened with ``keys_sep``. Every value must be a number or a
    single-element tensor. Device tensors are stacked on their device (float64) and copied in one transfer.
    """
    if isinstance(metrics, TensorDictBase):
        flat = dict(metrics.flatten_keys(keys_sep).items())
    elif isinstance(metrics, Mapping):
        flat = _flatten_metric_mapping(metrics, keys_sep)
    else:
        raise TypeError(f"metrics must be a dict or a TensorDict, got {type(metrics).__name__}")
    out: dict[str, float | int] = {}
    on_device: dict[torch.device, list[tuple[str, torch.Tensor]]] = {}
    for name, value in flat.items():
        if isinstance(value, torch.Tensor) and value.device.type != "cpu":
            if value.numel() != 1:
                _python_scalar(name, value)  # raises the shape error
            on_device.setdefault(value.device, []).append((name, value))
            out[name] = 0  # placeholder, keeps the caller's key order
        else:
            out[name] = _python_scalar(name, value)
    for entries in on_device.values():
        stacked = torch.stack([v.detach().reshape(()).to(torch.float64) for _, v in entries]).cpu()  # one sync
        for (name, value), host in zip(entries, stacked.tolist(), strict=True):
            integral = not (value.dtype.is_floating_point or value.dtype.is_complex)
            out[name] = int(host) if integral else host
    return out


def _as_step(step: Any) -> int:
    if isinstance(step, torch.Tensor):
        step = step.item()
    if isinstance(step, np.generic):
        step = step.item()
    if isinstance(step, bool) or not isinstance(step, (int, float)):
        raise TypeError(f"step must be an integer, got {step!r}")
    if isinstance(step, float):
        if not step.is_integer():
            raise ValueError(f"step must be an integer, got {step!r}")
        step = int(step)
    return step


def _json_value(value: Any) -> Any:
    """A JSON-safe version of one hyperparameter leaf value."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, np.generic):
        return _json_value(value.item())
    if isinstance(value, torch.Tensor):
        return _json_value(value.item()) if value.numel() == 1 else str(value.tolist())
    if isinstance(value, enum.Enum):
        return _json_value(value.value) if isinstance(value.value, (int, str)) else value.name
    if isinstance(value, (Path, torch.device, torch.dtype)):
        return str(value)
    return repr(value)


def flatten_hparams(cfg: Any, *, sep: str = ".") -> dict[str, Any]:
    """Flatten a (nested) hyperparameter config into ``{"a.b.c": json_value}``.

    Accepts dicts, OmegaConf ``DictConfig`` (resolved), dataclass instances. Lists of scalars stay lists;
    lists containing mappings are flattened with their index (``a.0.b``). Other leaves become strings.
    """
    try:
        from omegaconf import DictConfig, ListConfig, OmegaConf

        if isinstance(cfg, (DictConfig, ListConfig)):
            cfg = OmegaConf.to_container(cfg, resolve=True)
    except ImportError:  # pragma: no cover - omegaconf is a dependency
        pass
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        cfg = dataclasses.asdict(cfg)
    if not isinstance(cfg, Mapping):
        raise TypeError(f"hyperparameters must be a mapping, DictConfig or dataclass, got {type(cfg).__name__}")
    out: dict[str, Any] = {}

    def visit(prefix: str, node: Any) -> None:
        if dataclasses.is_dataclass(node) and not isinstance(node, type):
            node = dataclasses.asdict(node)
        if isinstance(node, Mapping):
            if not node and prefix:
                out[prefix] = {}
            for key, child in node.items():
                visit(f"{prefix}{sep}{key}" if prefix else str(key), child)
        elif isinstance(node, (list, tuple)):
            if any(isinstance(x, (Mapping, list, tuple)) or dataclasses.is_dataclass(x) for x in node):
                for i, child in enumerate(node):
                    visit(f"{prefix}{sep}{i}", child)
            else:
                out[prefix] = [_json_value(x) for x in node]
        else:
            out[prefix] = _json_value(node)

    visit("", cfg)
    return out


def _video_to_frames(video: Any) -> np.ndarray:
    """``[T, C, H, W]``, ``[N, T, C, H, W]`` (N tiled horizontally) or channel-last variants -> uint8 ``[T, H, W, C]``."""
    v = torch.as_tensor(video).detach().cpu()
    channels = (1, 3, 4)
    if v.ndim == 3:  # [T, H, W] grayscale
        v = v.unsqueeze(-1)
    elif v.ndim in (4, 5):
        if v.shape[-3] in channels:  # channel-first
            v = v.movedim(-3, -1)
        elif v.shape[-1] not in channels:
            raise ValueError(
                f"video of shape {tuple(v.shape)}: expected [T, C, H, W] or [N, T, C, H, W] with C in {channels} "
                "(or channel-last)"
            )
        if v.ndim == 5:  # [N, T, H, W, C] -> [T, H, N * W, C]
            n, t, h, w, c = v.shape
            v = v.permute(1, 2, 0, 3, 4).reshape(t, h, n * w, c)
    else:
        raise ValueError(f"video must have 3 to 5 dims ([T, C, H, W] or [N, T, C, H, W]), got shape {tuple(v.shape)}")
    if v.dtype.is_floating_point:
        v = (v.clamp(0, 1) * 255).round()
    return v.clamp(0, 255).to(torch.uint8).numpy()


def _png_bytes(frame: np.ndarray) -> bytes:
    try:
        from PIL import Image
    except ImportError as err:  # pragma: no cover - Pillow ships with matplotlib
        raise ImportError("MCAPLogger.log_video(video='png') needs Pillow: pip install pillow") from err
    if frame.shape[-1] == 1:
        image = Image.fromarray(frame[..., 0], mode="L")
    else:
        image = Image.fromarray(frame, mode="RGB" if frame.shape[-1] == 3 else "RGBA")
    buf = io.BytesIO()
    image.save(buf, format="PNG")
    return buf.getvalue()


# ----------------------------------------------------------------------------------------------------------------
# The logger
# ----------------------------------------------------------------------------------------------------------------
class MCAPLogger(Logger):
    """A torchrl ``Logger`` writing ``<log_dir>/<exp_name>.mcap`` (JSON + JSON-Schema, readable by MCAP tools).

    Args:
        exp_name: experiment name; the file is ``<log_dir>/<exp_name>.mcap`` (no path separators).
        log_dir: directory of the file (created). Defaults to ``"runs"``.

    Keyword Args:
        if_exists: what to do when ``<exp_name>.mcap`` exists: ``"error"`` (default, raise
            ``FileExistsError``), ``"append"`` (resume: write the next segment ``<exp_name>.<k>.mcap``; the
            readers merge segments) or ``"overwrite"`` (delete this experiment's segment files first).
        flush_interval_s: a background thread finalizes the current chunk and flushes the file this often
            when something was logged (a killed process loses at most this much). ``None`` disables it
            (data then reaches the file when a 1 MiB chunk fills, on :meth:`flush` and on :meth:`close`).
        compression: chunk compression, ``"zstd"`` (default), ``"lz4"`` or ``"none"``.
        chunk_size: chunk size threshold in bytes (default 1 MiB).
        video: ``"png"`` (default: every frame becomes a ``foxglove.CompressedImage`` PNG message on
            ``/video/<name>``) or ``"skip"`` (store nothing, warn once).
        video_fps: frame rate used for the frame timestamps when ``log_video`` gets no ``fps``.

    Step semantics: ``step=None`` uses a per-name counter (number of values logged so far under that name,
    kept in :meth:`state_dict`).
    """

    experiment: MCAPRun

    def __init__(
        self,
        exp_name: str,
        log_dir: str = "runs",
        *,
        if_exists: Literal["error", "append", "overwrite"] = "error",
        flush_interval_s: float | None = 5.0,
        compression: Literal["zstd", "lz4", "none"] = "zstd",
        chunk_size: int = 1024 * 1024,
        video: Literal["png", "skip"] = "png",
        video_fps: int = 30,
    ) -> None:
        if not exp_name or "/" in exp_name or os.sep in exp_name or exp_name in (".", ".."):
            raise ValueError(f"exp_name must be a non-empty file name without path separators, got {exp_name!r}")
        if if_exists not in _IF_EXISTS:
            raise ValueError(f"if_exists must be one of {_IF_EXISTS}, got {if_exists!r}")
        if compression not in _COMPRESSIONS:
            raise ValueError(f"compression must be one of {tuple(_COMPRESSIONS)}, got {compression!r}")
        if video not in _VIDEO_MODES:
            raise ValueError(f"video must be one of {_VIDEO_MODES}, got {video!r}")
        if flush_interval_s is not None and not flush_interval_s > 0:
            raise ValueError(f"flush_interval_s must be > 0 or None, got {flush_interval_s!r}")
        self._if_exists = if_exists
        self._flush_interval_s = flush_interval_s
        self._compression = compression
        self._chunk_size = int(chunk_size)
        self._video_mode = video
        self.video_fps = int(video_fps)
        self._video_warned = False
        self._counters: dict[str, int] = {}
        self.segment = 0
        super().__init__(exp_name=exp_name, log_dir=log_dir)

    # -- torchrl Logger API --------------------------------------------------------------------------------------
    def _existing_segments(self) -> list[tuple[int, Path]]:
        found = []
        for candidate in Path(self.log_dir).glob("*.mcap"):
            try:
                guess, _ = parse_segment_filename(candidate)
            except ValueError:
                continue
            if guess != self.exp_name and candidate.name != f"{self.exp_name}.mcap":
                continue
            meta = read_run_metadata(candidate) if candidate.stat().st_size else None
            exp, segment = (meta["exp_name"], int(meta["segment"])) if meta else parse_segment_filename(candidate)
            if exp == self.exp_name:
                found.append((segment, candidate))
        return sorted(found)

    def _create_experiment(self) -> MCAPRun:
        """Open the segment file (called once by ``Logger.__init__``)."""
        os.makedirs(self.log_dir, exist_ok=True)
        existing = self._existing_segments()
        if existing:
            if self._if_exists == "error":
                raise FileExistsError(
                    f"{existing[0][1]} exists; pass if_exists='append' to resume it in a new segment file or "
                    "if_exists='overwrite' to replace it (or use another exp_name)"
                )
            if self._if_exists == "overwrite":
                for _, file in existing:
                    file.unlink()
                self.segment = 0
            else:
                self.segment = existing[-1][0] + 1
        return self._open_segment()

    def _open_segment(self) -> MCAPRun:
        """Open the file of segment ``self.segment``."""
        path = segment_path(self.log_dir, self.exp_name, self.segment)
        if path.exists():  # a stray file with this name that belongs to another experiment
            raise FileExistsError(f"{path} exists and is not a segment of experiment {self.exp_name!r}")
        metadata = {
            "exp_name": self.exp_name,
            "segment": str(self.segment),
            "format_version": FORMAT_VERSION,
            "created_unix_ns": str(time.time_ns()),
            "hostname": socket.gethostname(),
            "pid": str(os.getpid()),
            "mtbench_version": mtbench.__version__,
        }
        return MCAPRun(
            path,
            metadata=metadata,
            compression=self._compression,
            chunk_size=self._chunk_size,
            flush_interval_s=self._flush_interval_s,
        )

    @property
    def path(self) -> Path:
        """The MCAP file written by this logger (``<log_dir>/<exp_name>.mcap`` or ``.<segment>.mcap``)."""
        return self.experiment.path

    def _next_step(self, name: str, step: Any) -> int:
        resolved = self._counters.get(name, 0) if step is None else _as_step(step)
        self._counters[name] = max(self._counters.get(name, 0), resolved + 1)
        return resolved

    def _scalar_payloads(
        self, values: Mapping[str, float | int], step: Any, log_time: int
    ) -> list[tuple[int, dict[str, Any]]]:
        wall_time = log_time / 1e9
        payloads = []
        for name, value in values.items():
            encoded, nonfinite = encode_float(float(value))
            payload: dict[str, Any] = {
                "step": self._next_step(name, step),
                "name": name,
                "value": int(value) if isinstance(value, int) and nonfinite is None else encoded,
                "wall_time": wall_time,
            }
            if nonfinite is not None:
                payload["nonfinite"] = nonfinite
            payloads.append((log_time, payload))
        return payloads

    def log_scalar(self, name: str, value: float, step: int | None = None) -> None:
        """Write one ``/scalars`` message. A device tensor costs one sync: prefer :meth:`log_metrics` for many."""
        number = _python_scalar(name, value)
        self.experiment.write(
            TOPIC_SCALARS, SCHEMA_SCALAR, self._scalar_payloads({name: number}, step, time.time_ns())
        )

    def log_metrics(
        self,
        metrics: Mapping[str, Any] | TensorDictBase,
        step: int | None = None,
        *,
        keys_sep: str = "/",
    ) -> dict[str, float | int]:
        """Write one ``/scalars`` message per metric, all with the same step and log time.

        Tensor values (CPU or CUDA, single-element) are brought to the host with one sync per device.
        Returns the converted ``{name: number}`` dict.
        """
        values = metrics_to_host(metrics, keys_sep=keys_sep)
        if values:
            self.experiment.write(TOPIC_SCALARS, SCHEMA_SCALAR, self._scalar_payloads(values, step, time.time_ns()))
        return values

    def log_hparams(self, cfg: Any) -> None:
        """Write the flattened hyperparameters (dict, ``DictConfig`` or dataclass) as one ``/hparams`` message."""
        log_time = time.time_ns()
        payload = {"wall_time": log_time / 1e9, "hparams": flatten_hparams(cfg)}
        self.experiment.write(TOPIC_HPARAMS, SCHEMA_HPARAMS, [(log_time, payload)])

    def log_histogram(self, name: str, data: Sequence | torch.Tensor | np.ndarray, **kwargs: Any) -> None:
        """Write a histogram of the finite values of ``data`` on ``/histograms``.

        Keyword Args:
            step (int, optional): step (default: per-name counter).
            bins (int | sequence | str): ``numpy.histogram`` bins (default 64).
            range (tuple[float, float], optional): ``numpy.histogram`` range.
            walltime (float, optional): override the wall time (Unix seconds).
        """
        step = kwargs.pop("step", None)
        bins = kwargs.pop("bins", 64)
        value_range = kwargs.pop("range", None)
        walltime = kwargs.pop("walltime", None)
        if kwargs:
            raise TypeError(f"log_histogram got unexpected arguments {sorted(kwargs)}; valid: step, bins, range, walltime")
        if isinstance(data, torch.Tensor):
            array = data.detach().to("cpu", torch.float64).numpy().ravel()
        else:
            array = np.asarray(data, dtype=np.float64).ravel()
        if array.size == 0:
            raise ValueError(f"log_histogram({name!r}): data is empty")
        finite = array[np.isfinite(array)]
        counts, edges = np.histogram(finite, bins=bins, range=value_range)
        log_time = time.time_ns() if walltime is None else int(float(walltime) * 1e9)
        has = finite.size > 0
        payload = {
            "step": self._next_step(name, step),
            "name": name,
            "wall_time": log_time / 1e9,
            "bin_edges": edges.tolist(),
            "counts": counts.tolist(),
            "count": int(finite.size),
            "nonfinite_count": int(array.size - finite.size),
            "min": float(finite.min()) if has else None,
            "max": float(finite.max()) if has else None,
            "mean": float(finite.mean()) if has else None,
            "std": float(finite.std()) if has else None,
        }
        self.experiment.write(TOPIC_HISTOGRAMS, SCHEMA_HISTOGRAM, [(log_time, payload)])

    def log_video(self, name: str, video: torch.Tensor, step: int | None = None, **kwargs: Any) -> None:
        """Store the frames as PNG ``foxglove.CompressedImage`` messages on ``/video/<name>`` (or skip, see ``video``).

        ``video``: ``[T, C, H, W]`` or ``[N, T, C, H, W]`` (N tiled side by side; channel-last also accepted),
        uint8 or float in [0, 1]. Frame ``i`` gets log time ``now + i / fps``. Keyword: ``fps``.
        """
        fps = kwargs.pop("fps", self.video_fps)
        if kwargs:
            raise TypeError(f"log_video got unexpected arguments {sorted(kwargs)}; valid: fps")
        if self._video_mode == "skip":
            if not self._video_warned:
                _log.warning("MCAPLogger(video='skip'): videos are not stored (first one: %r)", name)
                self._video_warned = True
            return
        if not fps > 0:
            raise ValueError(f"fps must be > 0, got {fps!r}")
        frames = _video_to_frames(video)
        step_value = self._next_step(f"{VIDEO_TOPIC_PREFIX}{name}", step)
        start = time.time_ns()
        payloads = []
        for i, frame in enumerate(frames):
            log_time = start + round(i * 1e9 / fps)
            payloads.append(
                (
                    log_time,
                    {
                        "timestamp": {"sec": log_time // 1_000_000_000, "nsec": log_time % 1_000_000_000},
                        "frame_id": name,
                        "data": base64.b64encode(_png_bytes(frame)).decode("ascii"),
                        "format": "png",
                        "step": step_value,
                        "frame_index": i,
                    },
                )
            )
        self.experiment.write(f"{VIDEO_TOPIC_PREFIX}{name}", SCHEMA_IMAGE, payloads)

    def flush(self, timeout: float | None = None) -> None:
        """Finalize the current chunk and flush the file (everything logged so far becomes readable)."""
        del timeout
        self.experiment.flush()

    def _checkpoint_state(self) -> dict[str, Any]:
        return {"counters": dict(self._counters), "segment": self.segment}

    def _load_checkpoint_state(self, state_dict: Mapping[str, Any]) -> None:
        self._counters.update({str(k): int(v) for k, v in state_dict.get("counters", {}).items()})
        saved = state_dict.get("segment")
        if saved is not None and int(saved) >= self.segment and not self.experiment.has_messages:
            # The checkpoint's log reached segment `saved` but this directory holds fewer segments (the run resumes
            # on another machine, or log files were lost): continue its numbering, so that the segments of both
            # places, put in one directory, merge in the order they were written.
            old = self.experiment
            old.close()
            old.path.unlink(missing_ok=True)
            self.segment = int(saved) + 1
            self.experiment = self._open_segment()

    def __repr__(self) -> str:
        return f"MCAPLogger(exp_name={self.exp_name!r}, path={str(self.experiment.path)!r})"

    def __del__(self) -> None:
        experiment = self.__dict__.get("experiment")
        if experiment is not None:
            try:
                experiment.close()
            except Exception:  # noqa: BLE001 - never raise from a finalizer
                pass


def _available(compression: str) -> str:
    """``compression`` if its codec is installed, else the next available of zstd -> lz4 -> none."""
    import importlib.util

    codecs = {"zstd": "zstandard", "lz4": "lz4"}
    for name in (compression, "zstd", "lz4"):
        if name == "none" or (name in codecs and importlib.util.find_spec(codecs[name]) is not None):
            return name
    return "none"
