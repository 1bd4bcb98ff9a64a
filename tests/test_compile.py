"""``compile=true`` trains with every gradient method (they backpropagate several task losses through one compiled
graph: before the fix FAMO, PCGrad and CAGrad failed with "compiled with non-empty donated buffers")."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from mtbench.trainer import build_trainer

CONF = str(Path(__file__).resolve().parents[1] / "conf")


@pytest.mark.parametrize("grad", ["none", "pcgrad", "cagrad", "famo"])
def test_compiled_networks_train_with_every_gradient_method(tmp_path: Path, grad: str) -> None:
    overrides = ["env=cpu_small", "env.num_envs=12", "device=cpu", "torch_threads=1", f"grad={grad}", "compile=true",
                 "arch.kwargs.hidden=[32,32]", "loss.horizon=8", "loss.epochs=1", "loss.minibatch_size=48",
                 "max_iterations=2", f"checkpoint.dir={tmp_path}", "logging.progress=none", "logging.logger=none"]
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    trainer = build_trainer(cfg)
    history = trainer.train()
    trainer.env.close()
    assert len(history) == 2
    losses = [v for k, v in history[-1].items() if k.startswith("loss/")]
    assert losses and all(math.isfinite(v) for v in losses)
