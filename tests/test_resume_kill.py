"""A real CPU job killed with SIGKILL after a checkpoint and resumed logs exactly the uninterrupted run's
metrics (timings aside), in its own run directory and MCAP log."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mtbench.logging import find_segments, read_scalars
from mtbench.trainer.checkpoint import load_checkpoint

ROOT = Path(__file__).resolve().parents[1]
TRAIN = [sys.executable, str(ROOT / "examples" / "train.py")]
JOB = ["env=cpu_small", "device=cpu", "env.num_envs=6", "loss.minibatch_size=96", "max_iterations=8",
       "checkpoint.every=2", "checkpoint.keep_last=0", "logging.progress=line"]
TIMING = ("fps", "fps_collect", "time/collect_s", "time/update_s")
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}  # this checkout


@pytest.mark.slow
def test_sigkill_after_a_checkpoint_then_resume_logs_the_uninterrupted_metrics_bit_for_bit(tmp_path: Path) -> None:
    full = subprocess.Popen([*TRAIN, *JOB, f"hydra.run.dir={tmp_path / 'full'}", "logging.exp_name=full",
                             f"logging.log_dir={tmp_path / 'full_runs'}"], cwd=tmp_path, env=ENV,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    run_dir = tmp_path / "run"
    killed = subprocess.Popen([*TRAIN, *JOB, f"hydra.run.dir={run_dir}", "logging.exp_name=run"], cwd=tmp_path, env=ENV,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    ckpt = run_dir / "checkpoints" / "ckpt_000002.pt"
    deadline = time.monotonic() + 600
    while not ckpt.exists() and killed.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    killed.send_signal(signal.SIGKILL)
    assert killed.wait() == -signal.SIGKILL, killed.stderr.read()
    assert not (run_dir / "checkpoints" / "final.pt").exists()  # killed mid-run
    assert full.wait(timeout=600) == 0, full.stderr.read()

    elsewhere = tmp_path / "elsewhere"  # the resume is started from another directory, naming only the checkpoint
    elsewhere.mkdir()
    resumed = subprocess.run([*TRAIN, *JOB, f"resume={ckpt}"], cwd=elsewhere, env=ENV, capture_output=True,
                             text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert "resumed from" in resumed.stdout and "at iteration 2" in resumed.stdout
    assert not list(elsewhere.iterdir()) and not (tmp_path / "outputs").exists()  # no new run directory
    assert load_checkpoint(run_dir / "checkpoints" / "final.pt")["counters"]["iteration"] == 8
    assert (run_dir / "checkpoints" / "ckpt_000008.pt").is_file()
    assert [p.name for p in find_segments(tmp_path / "runs")] == ["run.mcap", "run.1.mcap"]  # appended

    expected, got = read_scalars(tmp_path / "full_runs" / "full.mcap"), read_scalars(tmp_path / "runs" / "run.mcap")
    assert set(expected) == set(got) and len(expected["frames"]) == 8
    for name in expected:
        if name in TIMING:
            continue
        assert [s for s, _ in got[name]] == [s for s, _ in expected[name]], name
        for (_, a), (_, b) in zip(expected[name], got[name]):
            assert a == b or (math.isnan(a) and math.isnan(b)), (name, a, b)
