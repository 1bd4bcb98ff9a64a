"""benchmarks/carry_probe.py on a tiny CPU checkpoint: what it returns, that a probe is reproducible, that the steered
phase acts (it changes the rewards), and its errors. A one-iteration MT-PPO run on pick_place and reach (2 worlds
each, 30-step episodes) provides the checkpoint."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
import torch

from cpu_runs import train_on_cpu

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("carry_probe", ROOT / "benchmarks" / "carry_probe.py")
carry_probe = importlib.util.module_from_spec(spec)
spec.loader.exec_module(carry_probe)
STEPS = 30


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("probe_run")
    overrides = [
        "device=cpu", "env=cpu_small", "env.name=[pick_place,reach]", "env.num_envs=4",
        f"+env.overrides.episode_length={STEPS}", "arch.kwargs.hidden=[32,32]", "loss.horizon=8",
        "loss.minibatch_size=32", "loss.epochs=1", "max_iterations=1", "logging.progress=none", "checkpoint.every=0",
        f"checkpoint.dir={root / 'ckpt'}",
    ]
    train_on_cpu(overrides)
    return root / "ckpt" / "final.pt"


def test_probe_returns_per_step_distances_and_rewards(checkpoint: Path) -> None:
    a = carry_probe.probe(str(checkpoint), ["pick_place"], worlds_per_task=2, steer_from=10, gain=20.0, seed=1)
    b = carry_probe.probe(str(checkpoint), ["pick_place"], worlds_per_task=2, steer_from=10, gain=20.0, seed=1)
    r = a["pick_place"]
    assert r["distance"].shape == (STEPS, 2) and r["reward"].shape == (STEPS, 2) and r["episodes"] == 2
    assert r["height"].shape == (STEPS, 2) and r["hand"].shape == (STEPS, 2)
    assert (r["distance"] >= 0).all() and (r["hand"] >= 0).all() and torch.isfinite(r["reward"]).all()
    assert (r["height"] > 0.0).all() and (r["height"] < 0.5).all()  # pick_place's puck: on or above the table
    torch.testing.assert_close(a["pick_place"]["reward"], b["pick_place"]["reward"])  # same seed, same probe
    # the policy's own steps are the same with any later steering; the steered steps differ
    c = carry_probe.probe(str(checkpoint), ["pick_place"], worlds_per_task=2, steer_from=20, gain=20.0, seed=1)
    torch.testing.assert_close(c["pick_place"]["reward"][:10], r["reward"][:10])
    assert not torch.equal(c["pick_place"]["reward"][10:20], r["reward"][10:20])


def test_probe_errors_name_the_choices(checkpoint: Path) -> None:
    with pytest.raises(ValueError, match=r"unknown tasks \['push'\].*valid choices.*pick_place.*reach"):
        carry_probe.probe(str(checkpoint), ["push"], worlds_per_task=1, steer_from=5, gain=20.0)
    with pytest.raises(ValueError, match=r"steer_from=30 is out of range; it must be in \[0, 29\]"):
        carry_probe.probe(str(checkpoint), ["reach"], worlds_per_task=1, steer_from=30, gain=20.0)
