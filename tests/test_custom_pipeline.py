"""examples/custom_pipeline.py (mtbench env + MOORE actor + stock TorchRL Collector / ClipPPOLoss / GAE + PCGrad)
runs: 2 iterations on a 2-task subset, per-task success printed."""

from __future__ import annotations

import importlib.util
import math
import re
from pathlib import Path

import pytest
import torch

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "custom_pipeline.py"


def test_custom_pipeline_trains_two_iterations_on_a_small_task_subset(capsys: pytest.CaptureFixture[str]) -> None:
    spec = importlib.util.spec_from_file_location("custom_pipeline", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    threads = torch.get_num_threads()
    try:
        window = module.main(["--tasks", "reach,push", "--num-envs", "4", "--iterations", "2", "--horizon", "40",
                              "--epochs", "2"])
    finally:
        torch.set_num_threads(threads)
    out = capsys.readouterr().out
    losses = [float(v) for v in re.findall(r"iteration [12]/2: \d+ frames, success \S+, critic loss ([-\d.e+]+)", out)]
    assert len(losses) == 2 and all(math.isfinite(v) for v in losses), out
    assert "iteration 2/2: 320 frames" in out
    table = out.split("Per-task success over the last 5 iterations:")[1]
    assert all(re.search(rf"^{name}\s", table, re.M) for name in ("reach", "push", "mean")), table
    assert window.task_names == ["reach", "push"]
