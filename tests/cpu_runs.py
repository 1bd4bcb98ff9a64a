"""Helpers for the tests that train or run documented code on the CPU: one intra-op thread (tiny tensors on a busy
2-core machine), configs composed from ``conf/`` (and trained to the end), metrics of two runs compared, and the
stock-TorchRL sketch of a doc page executed with small sizes."""

from __future__ import annotations

import contextlib
import math
import re
from pathlib import Path
from typing import Any, Iterator, Sequence

import torch
from hydra import compose, initialize_config_dir
from omegaconf import DictConfig

from mtbench.trainer import build_trainer

ROOT = Path(__file__).resolve().parents[1]
CONF = str(ROOT / "conf")
#: metrics that measure time, not the run (they differ between two identical runs)
TIMING_KEYS = ("fps", "fps_collect", "time/collect_s", "time/update_s")


@contextlib.contextmanager
def one_torch_thread() -> Iterator[None]:
    """``torch.set_num_threads(1)`` inside the block, the previous count restored afterwards."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def compose_config(overrides: Sequence[str]) -> DictConfig:
    """``conf/config.yaml`` composed with the Hydra ``overrides``."""
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        return compose("config", overrides=list(overrides))


def assert_same_metrics(a: dict[str, float], b: dict[str, float]) -> None:
    """The two iterations' metrics are equal, key by key (NaN equals NaN), except the timings."""
    assert set(a) == set(b)
    for key in a:
        if key not in TIMING_KEYS:
            assert a[key] == b[key] or (math.isnan(a[key]) and math.isnan(b[key])), key


def train_on_cpu(overrides: Sequence[str]) -> tuple[Any, list[dict[str, float]]]:
    """Compose ``conf/config.yaml`` with ``overrides``, build the run and train it with one torch thread; returns
    the trainer and its per-iteration metrics."""
    cfg = compose_config(overrides)
    with one_torch_thread():
        trainer = build_trainer(cfg)
        history = trainer.train()
    return trainer, history


def run_doc_snippet(doc: str, replacements: Sequence[tuple[str, str]]) -> dict[str, Any]:
    """Execute the python block of the section "Using the parts in a stock TorchRL pipeline" of ``docs/<doc>``
    with one torch thread, after each ``(old, new)`` replacement (every ``old`` must occur: the doc and the test
    stay in step); returns the block's global namespace."""
    text = (ROOT / "docs" / doc).read_text()
    code = re.search(r"## Using the parts in a stock TorchRL pipeline\n\n```python\n(.*?)```", text, re.S).group(1)
    for old, new in replacements:
        assert old in code, old
        code = code.replace(old, new)
    scope: dict[str, Any] = {}
    with one_torch_thread():
        exec(compile(code, f"docs/{doc}", "exec"), scope)
    return scope
