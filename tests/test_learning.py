"""A short seeded MT-PPO run on the real physics env learns: success on ``reach`` rises well above chance.

Chance level: a random policy (the initial Gaussian policy, sigma = 1) almost never brings the TCP within 5 cm
of a goal 15-35 cm away in a 60-step episode. When this test was written, the first measured success of the run
was 0.00 and the final one (57,600 frames, ~45 s on 2 CPU cores) 1.00; the thresholds (first < 0.3,
final >= 0.6) leave a wide margin, so the test fails only if learning is really broken.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cpu_runs import train_on_cpu


@pytest.mark.slow
def test_short_seeded_cpu_training_learns_reach(tmp_path: Path) -> None:
    overrides = [
        "device=cpu",
        "seed=0",
        "env.name=reach",
        "env.num_envs=32",
        "+env.overrides.episode_length=60",
        "loss.horizon=30",
        "loss.epochs=5",
        "loss.minibatch_size=480",
        "max_iterations=60",
        "logging.progress=none",
        "checkpoint.every=0",
        "checkpoint.save_final=false",
        f"checkpoint.dir={tmp_path}",
    ]
    trainer, history = train_on_cpu(overrides)  # one torch thread: small batches on a 2-core machine
    measured = [h["success/mean"] for h in history if math.isfinite(h["success/mean"])]  # NaN: no episode yet
    early, late = measured[0], history[-1]["success/mean"]
    print(f"reach success: first measured {early:.2f}, final {late:.2f}")
    assert early < 0.3, f"success already {early:.2f} before learning"
    assert late >= 0.6, f"success after {trainer.frames} frames is only {late:.2f}"
