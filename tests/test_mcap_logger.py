"""MCAPLogger: round trips, MCAP-level layout, crash tolerance, segments, and the ``mtbench.logs`` CLI."""

from __future__ import annotations

import base64
import gc
import io
import json
import math
import os
import shutil
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
from mcap.reader import NonSeekingReader, make_reader
from tensordict import TensorDict

from mtbench.logging import (
    MCAPLogger,
    TruncatedMCAPWarning,
    find_segments,
    iter_messages,
    read_histograms,
    read_hparams,
    read_run_metadata,
    read_scalars,
)
from mtbench.logging.mcap_logger import flatten_hparams, metrics_to_host
from mtbench.logs import main as logs_main

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _logger(tmp_path: Path, name: str = "run", **kwargs) -> MCAPLogger:
    kwargs.setdefault("flush_interval_s", None)
    return MCAPLogger(name, log_dir=str(tmp_path), **kwargs)


def test_round_trip_scalars_metrics_hparams(tmp_path: Path) -> None:
    logger = _logger(tmp_path)
    assert logger.path == tmp_path / "run.mcap"
    cfg = {"optim": {"lr": 3e-4, "betas": [0.9, 0.999]}, "env": {"tasks": ["reach-v3", "push-v3"]}, "seed": 7,
           "loss": {"clip": None, "type": "ppo"}, "bad": float("inf")}
    logger.log_hparams(cfg)
    expected: dict[str, list[tuple[int, float]]] = {}
    for step in range(0, 500, 50):
        loss = torch.tensor(1.0 / (step + 1))  # float32: the stored value is the float32 value
        metrics = {"loss/actor": loss, "frames": torch.tensor(step * 64), "success/reach-v3": step / 1000.0,
                   "done": torch.tensor(True), "eval": {"return": np.float32(step)}}
        out = logger.log_metrics(metrics, step=step)
        assert out["frames"] == step * 64 and isinstance(out["frames"], int)
        assert out["done"] == 1
        for name, value in (("loss/actor", loss.item()), ("frames", step * 64), ("success/reach-v3", step / 1000.0),
                            ("done", 1.0), ("eval/return", float(np.float32(step)))):
            expected.setdefault(name, []).append((step, value))
    logger.log_scalar("loss/nan", float("nan"), step=3)
    logger.log_scalar("loss/nan", float("-inf"), step=4)
    logger.log_scalar("auto", 1.5)  # step=None -> per-name counter
    logger.log_scalar("auto", torch.tensor([2.5]))
    logger.close()

    scalars = read_scalars(tmp_path / "run.mcap")
    for name, points in expected.items():
        assert scalars[name] == points, name
    assert [s for s, _ in scalars["loss/nan"]] == [3, 4]
    assert math.isnan(scalars["loss/nan"][0][1]) and scalars["loss/nan"][1][1] == -math.inf
    assert scalars["auto"] == [(0, 1.5), (1, 2.5)]
    assert set(scalars) == set(expected) | {"loss/nan", "auto"}

    hparams = read_hparams(tmp_path / "run.mcap")
    assert hparams == {"optim.lr": 3e-4, "optim.betas": [0.9, 0.999], "env.tasks": ["reach-v3", "push-v3"],
                       "seed": 7, "loss.clip": None, "loss.type": "ppo", "bad": "inf"}
    assert read_scalars(tmp_path) == scalars  # directory form


def test_file_layout_with_mcap_reader(tmp_path: Path) -> None:
    logger = _logger(tmp_path, compression="lz4")
    logger.log_hparams({"a": 1})
    for step in range(7):
        logger.log_metrics({"x": float(step), "y": torch.tensor(float(step))}, step=step)
    logger.log_scalar("z", 1.0, step=0)
    logger.log_histogram("actions", torch.linspace(-1, 1, 101), step=3, bins=4)
    video = torch.randint(0, 256, (1, 4, 3, 8, 10), dtype=torch.uint8)  # [N, T, C, H, W] like VideoRecorder
    logger.log_video("rollout", video, step=2, fps=10)
    logger.close()

    with open(tmp_path / "run.mcap", "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        topics = {c.topic: c for c in summary.channels.values()}
        assert set(topics) == {"/hparams", "/scalars", "/histograms", "/video/rollout"}
        counts = {t: summary.statistics.channel_message_counts[c.id] for t, c in topics.items()}
        assert counts == {"/hparams": 1, "/scalars": 15, "/histograms": 1, "/video/rollout": 4}
        schema_names = {t: summary.schemas[c.schema_id].name for t, c in topics.items()}
        assert schema_names == {"/hparams": "mtbench.HParams", "/scalars": "mtbench.Scalar",
                                "/histograms": "mtbench.Histogram", "/video/rollout": "foxglove.CompressedImage"}
        for channel in topics.values():
            schema = summary.schemas[channel.schema_id]
            assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
            assert json.loads(schema.data)["type"] == "object"
        (meta,) = list(reader.iter_metadata())
        assert meta.name == "mtbench.run" and meta.metadata["exp_name"] == "run" and meta.metadata["segment"] == "0"
        decoded = [(c.topic, json.loads(m.data)) for _, c, m in reader.iter_messages(topics=["/scalars"])]
        assert len(decoded) == 15 and all({"step", "name", "value", "wall_time"} <= set(d) for _, d in decoded)
        # log_time is wall time in ns
        first = next(reader.iter_messages(topics=["/scalars"]))[2]
        assert abs(first.log_time / 1e9 - time.time()) < 60
        assert json.loads(first.data)["wall_time"] == pytest.approx(first.log_time / 1e9)
    with open(tmp_path / "run.mcap", "rb") as f:  # the data-section CRC path of the linear reader
        assert sum(1 for _ in NonSeekingReader(f, validate_crcs=True).iter_messages()) == 21

    (hist,) = read_histograms(tmp_path)["actions"]
    assert hist["step"] == 3 and hist["counts"] == [25, 25, 25, 26] and hist["count"] == 101
    assert hist["bin_edges"] == pytest.approx([-1, -0.5, 0, 0.5, 1]) and hist["mean"] == pytest.approx(0.0, abs=1e-7)

    frames = [m for _, _, m in iter_messages(tmp_path / "run.mcap", topics=["/video/rollout"])]
    from PIL import Image

    for i, msg in enumerate(frames):
        assert msg["format"] == "png" and msg["frame_index"] == i and msg["step"] == 2
        image = np.asarray(Image.open(io.BytesIO(base64.b64decode(msg["data"]))))
        np.testing.assert_array_equal(image, video[0, i].permute(1, 2, 0).numpy())
    stamps = [m["timestamp"]["sec"] * 10**9 + m["timestamp"]["nsec"] for m in frames]
    assert np.diff(stamps).tolist() == [100_000_000] * 3  # 10 fps


def test_tensor_values_are_converted_without_cuda(tmp_path: Path) -> None:
    td = TensorDict({"loss": {"actor": torch.tensor(0.5), "critic": torch.tensor([0.25])},
                     "frames": torch.tensor(4096, dtype=torch.int64)}, batch_size=[])
    assert metrics_to_host(td) == {"loss/actor": 0.5, "loss/critic": 0.25, "frames": 4096}
    assert metrics_to_host(td, keys_sep=".")["loss.actor"] == 0.5
    with pytest.raises(ValueError, match="only single-element"):
        metrics_to_host({"per_task": torch.zeros(3)})
    with pytest.raises(TypeError, match="'name'"):
        metrics_to_host({"name": "ppo"})
    logger = _logger(tmp_path)
    logger.log_metrics(td, step=10)
    logger.close()
    assert read_scalars(tmp_path) == {"frames": [(10, 4096.0)], "loss/actor": [(10, 0.5)], "loss/critic": [(10, 0.25)]}


def test_flatten_hparams_and_validation(tmp_path: Path) -> None:
    from omegaconf import OmegaConf

    cfg = OmegaConf.create({"a": {"b": 2, "c": "${a.b}"}, "nets": [{"h": 1}, {"h": 2}], "e": {}})
    assert flatten_hparams(cfg) == {"a.b": 2, "a.c": 2, "nets.0.h": 1, "nets.1.h": 2, "e": {}}
    with pytest.raises(ValueError, match="if_exists must be one of"):
        _logger(tmp_path, if_exists="resume")
    with pytest.raises(ValueError, match="path separators"):
        MCAPLogger("a/b", log_dir=str(tmp_path))
    logger = _logger(tmp_path)
    with pytest.raises(TypeError, match="valid: step, bins, range, walltime"):
        logger.log_histogram("h", [1.0], foo=1)
    logger.close()
    with pytest.raises(RuntimeError, match="closed"):
        logger.log_scalar("x", 1.0, step=0)


def test_unfinished_file_readable_up_to_last_flush(tmp_path: Path) -> None:
    logger = _logger(tmp_path)
    for step in range(5):
        logger.log_scalar("x", float(step), step=step)
    logger.flush()
    size_after_one_chunk = logger.path.stat().st_size
    for step in range(5, 9):  # buffered in the open chunk: lost if the process dies now
        logger.log_scalar("x", float(step), step=step)
    killed = tmp_path / "killed" / "run.mcap"
    killed.parent.mkdir()
    shutil.copyfile(logger.path, killed)  # what is on disk when the process is SIGKILLed here
    with pytest.warns(TruncatedMCAPWarning, match="no MCAP footer"):
        assert read_scalars(killed) == {"x": [(s, float(s)) for s in range(5)]}

    logger.flush()
    size_after_two_chunks = logger.path.stat().st_size
    logger.close()
    assert read_scalars(logger.path)["x"] == [(s, float(s)) for s in range(9)]
    # cut the finished file inside its summary, then inside the second chunk record
    data = logger.path.read_bytes()
    for cut, expected_steps in ((size_after_two_chunks + 20, 9), (size_after_one_chunk + 20, 5)):
        (killed.parent / "run.mcap").write_bytes(data[:cut])
        with pytest.warns(TruncatedMCAPWarning):
            assert [s for s, _ in read_scalars(killed)["x"]] == list(range(expected_steps))


def test_periodic_flush_thread(tmp_path: Path) -> None:
    logger = MCAPLogger("run", log_dir=str(tmp_path), flush_interval_s=0.05)
    logger.log_metrics({"x": 1.0}, step=0)
    deadline = time.monotonic() + 5.0
    found: dict = {}
    while time.monotonic() < deadline and not found:
        time.sleep(0.05)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TruncatedMCAPWarning)
            found = read_scalars(logger.path)
    assert found == {"x": [(0, 1.0)]}
    logger.close()


def test_segments_append_merge_and_overwrite(tmp_path: Path) -> None:
    first = _logger(tmp_path)
    first.log_hparams({"lr": 1.0, "seed": 1})
    for step in range(10):  # the dead run logged up to step 9 ...
        first.log_metrics({"loss": float(step), "only_first": 1.0}, step=step)
    state = first.state_dict()
    first.close()
    with pytest.raises(FileExistsError, match="if_exists='append'"):
        _logger(tmp_path)

    second = _logger(tmp_path, if_exists="append")  # ... and resumed from a checkpoint at step 6
    assert second.path == tmp_path / "run.1.mcap" and second.segment == 1
    second.load_state_dict(state)
    second.log_hparams({"lr": 2.0})
    for step in range(6, 12):
        second.log_metrics({"loss": 100.0 + step}, step=step)
    second.log_scalar("counter", 1.0)
    second.close()
    assert read_run_metadata(second.path)["segment"] == "1"

    assert find_segments(tmp_path / "run.1.mcap") == [tmp_path / "run.mcap", tmp_path / "run.1.mcap"]
    scalars = read_scalars(tmp_path / "run.mcap")
    assert scalars["loss"] == [(s, float(s)) for s in range(6)] + [(s, 100.0 + s) for s in range(6, 12)]
    assert len(scalars["only_first"]) == 10
    assert scalars["counter"] == [(0, 1.0)]
    assert read_scalars(tmp_path / "run.1.mcap", all_segments=False)["loss"][0] == (6, 106.0)
    assert read_hparams(tmp_path) == {"lr": 2.0, "seed": 1}

    dotted = _logger(tmp_path, name="run.7")  # its file name looks like segment 7 of "run": metadata disambiguates
    dotted.log_scalar("loss", -1.0, step=0)
    dotted.close()
    assert find_segments(tmp_path / "run.7.mcap") == [tmp_path / "run.7.mcap"]
    assert read_scalars(tmp_path / "run.mcap")["loss"] == scalars["loss"]
    dotted.path.unlink()

    other = _logger(tmp_path, name="other")
    other.close()
    with pytest.raises(ValueError, match="several experiments"):
        read_scalars(tmp_path)
    third = _logger(tmp_path, if_exists="overwrite")
    third.log_scalar("loss", 5.0, step=0)
    third.close()
    assert sorted(p.name for p in tmp_path.glob("*.mcap")) == ["other.mcap", "run.mcap"]
    assert read_scalars(tmp_path / "run.mcap") == {"loss": [(0, 5.0)]}


def test_forked_child_does_not_corrupt_parent_file(tmp_path: Path) -> None:
    # Small chunks: finalized chunks sit in the file buffer at fork time; a child finalizing its copy of the
    # logger must neither write them again nor write a footer.
    logger = _logger(tmp_path, chunk_size=200)
    for step in range(30):
        logger.log_scalar("x", float(step), step=step)
    pid = os.fork()
    if pid == 0:  # pragma: no cover - child
        try:
            logger.close()
            del logger
            gc.collect()
        finally:
            os._exit(0)
    assert os.waitpid(pid, 0)[1] == 0
    for step in range(30, 60):
        logger.log_scalar("x", float(step), step=step)
    logger.close()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_scalars(logger.path)["x"] == [(s, float(s)) for s in range(60)]


def _cli_run(tmp_path: Path) -> Path:
    logger = _logger(tmp_path, name="cli")
    tasks = ["push-v3", "reach-v3"]  # sorted output order: push, reach
    for it in range(20):
        metrics = {"frames": 1000 * (it + 1), "loss/actor": 10.0 - it, "loss/critic/q1": float(it), "loss_alpha": 0.5}
        metrics["success/reach-v3"] = it / 20  # last 0.95, mean(last 4) = (16+17+18+19)/80 = 0.875
        metrics["success/push-v3"] = 0.1  # last 0.1
        metrics["return/reach-v3"] = float(2 * it)  # last 38, mean(last 4) = 35
        metrics["return/push-v3"] = 4.0
        logger.log_metrics(metrics, step=it)
    del tasks
    logger.close()
    return logger.path


def test_cli_summary_and_plots(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _cli_run(tmp_path)
    out_dir = tmp_path / "plots"
    assert logs_main([str(path), "--out", str(out_dir), "--last", "4"]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines() if line.strip()}
    assert rows["loss/actor"] == ["-9", "-7.5", "10", "20"]  # last, mean(last 4), max, points
    assert rows["frames"] == ["20000", "18500", "20000", "20"]
    assert rows["success/reach-v3"] == ["0.95", "0.875", "0.95", "20"]
    assert rows["reach-v3"] == ["0.95", "0.875", "38", "35"]  # task table
    assert rows["push-v3"] == ["0.1", "0.1", "4", "4"]
    assert rows["mean"] == ["0.525", "0.4875", "21", "19.5"]
    task_lines = [line.split()[0] for line in out.split("per task")[1].splitlines()[3:] if line.strip()]
    assert task_lines[:3] == ["push-v3", "reach-v3", "mean"]

    names = {"success_mean.png", "success_per_task.png", "loss_actor.png", "loss_critic.png", "loss_alpha.png"}
    assert {p.name for p in out_dir.iterdir()} == names
    for name in names:
        data = (out_dir / name).read_bytes()
        assert data[:8] == PNG_SIGNATURE and len(data) > 5000, name
        assert f"wrote {out_dir / name}" in out


def test_cli_module_entry_point_is_torch_free(tmp_path: Path) -> None:
    path = _cli_run(tmp_path)
    code = (
        "import runpy, sys\n"
        f"sys.argv = ['mtbench.logs', {str(path)!r}, '--out', {str(tmp_path / 'p')!r}]\n"
        "try:\n    runpy.run_module('mtbench.logs', run_name='__main__')\n"
        "except SystemExit as e:\n    assert e.code == 0, e.code\n"
        "print('torch imported:', 'torch' in sys.modules)\n"
    )
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": f"{root}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "torch imported: False" in proc.stdout
    assert f"wrote {tmp_path / 'p' / 'success_mean.png'}" in proc.stdout


def test_cli_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert logs_main([str(tmp_path / "missing.mcap")]) == 2
    assert "no such file" in capsys.readouterr().err
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all")
    assert logs_main([str(tmp_path / "junk.mcap")]) == 2
    assert "not a readable MCAP file" in capsys.readouterr().err


def test_plots_terrain_levels_and_offsets_frames(tmp_path: Path) -> None:
    """A Parkour curriculum run gets a terrain-level figure; --frames-offset shifts the frames axis (pre-training)."""
    from mtbench.logs import _x_axis, plot_run

    scalars = {
        "frames": [(1, 1000.0), (2, 2000.0), (3, 3000.0)],
        "success/stairs": [(1, 0.1), (2, 0.3), (3, 0.5)],
        "terrain_level/stairs": [(1, 0.0), (2, 1.0), (3, 2.0)],
        "terrain_level/gaps": [(1, 0.0), (3, 1.0)],
        "terrain_level/mean": [(1, 0.0), (3, 1.5)],
    }
    label, to_x = _x_axis(scalars, frames_offset=500.0)
    assert to_x([1, 3]).tolist() == [1500.0, 3500.0]
    assert to_x([2.5]).tolist() == [3000.0]  # interpolated between logged steps, then shifted
    assert label == "frames (including 500 before this run)"
    assert _x_axis(scalars)[1]([2]).tolist() == [2000.0]
    written = {p.name for p in plot_run(scalars, tmp_path, frames_offset=500.0)}
    assert written == {"success_mean.png", "success_per_task.png", "terrain_level.png"}
    assert (tmp_path / "terrain_level.png").read_bytes()[:8] == PNG_SIGNATURE
    without = {p.name for p in plot_run({k: v for k, v in scalars.items() if "terrain" not in k}, tmp_path / "b")}
    assert "terrain_level.png" not in without


def test_resume_on_another_machine_continues_segment_numbering(tmp_path: Path) -> None:
    """A checkpoint taken in segment 1 and resumed where the log directory is empty (a fresh GPU host) writes
    segment 2, not a second segment 0: copied into one directory, the segments merge in the order they were
    written (before the fix, the fresh host's segment 0 sorted first and the old segment 1 dropped its points)."""
    here, there = tmp_path / "host_a", tmp_path / "host_b"
    first = _logger(here)
    for step in range(5):
        first.log_metrics({"loss": float(step)}, step=step)
    first.close()
    second = _logger(here, if_exists="append")  # resumed once on the same machine: segment 1
    for step in range(5, 10):
        second.log_metrics({"loss": float(step)}, step=step)
    state = second.state_dict()  # the checkpoint at step 9
    second.close()

    third = _logger(there, if_exists="append")
    assert third.segment == 0
    third.load_state_dict(state)
    assert third.segment == 2 and third.path == there / "run.2.mcap"
    assert sorted(p.name for p in there.glob("*.mcap")) == ["run.2.mcap"]  # the empty segment 0 is gone
    for step in range(10, 15):
        third.log_metrics({"loss": float(step)}, step=step)
    third.close()
    assert read_run_metadata(third.path)["segment"] == "2"
    shutil.copy(third.path, here / third.path.name)
    assert read_scalars(here)["loss"] == [(s, float(s)) for s in range(15)]

    fourth = _logger(here, if_exists="append")  # the directory already holds segments 0-2: nothing to renumber
    assert fourth.segment == 3
    fourth.load_state_dict(state)
    assert fourth.segment == 3
    fourth.close()
