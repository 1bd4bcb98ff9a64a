"""Trainer: Hydra config composition, logging, per-task success, checkpoint/resume determinism, NaN guard."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import pytest
import torch
from hydra import compose, initialize_config_dir

from envs_for_tests import SyntheticMTEnv
from mtbench.trainer.checkpoint import load_checkpoint, save_checkpoint
from mtbench.trainer.trainer import Trainer

CONF = str(Path(__file__).resolve().parents[1] / "conf")
TIMING_KEYS = ("fps", "fps_collect", "time/collect_s", "time/update_s")


def _cfg(tmp_path: Path, *overrides: str):
    base = [
        "device=cpu",
        "arch.kwargs.hidden=[32,32]",
        "loss.horizon=8",
        "loss.epochs=2",
        "loss.minibatch_size=48",
        "max_iterations=4",
        f"checkpoint.dir={tmp_path / 'ckpt'}",
        "checkpoint.every=0",
        "logging.progress=none",
    ]
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        return compose("config", overrides=[*base, *overrides])


def _env(**kwargs: Any) -> SyntheticMTEnv:
    return SyntheticMTEnv([4, 4, 4], max_episode_steps=6, seed=0, **kwargs)


def _params(trainer: Trainer) -> dict[str, torch.Tensor]:
    return {k: v.detach().clone() for k, v in trainer.loss.named_parameters()}


class RecordingLogger:
    def __init__(self) -> None:
        self.metrics: list[tuple[dict[str, float], int]] = []
        self.hparams: list[Any] = []

    def log_metrics(self, metrics: dict[str, float], step: int | None = None) -> None:
        self.metrics.append((dict(metrics), step))

    def log_hparams(self, cfg: Any) -> None:
        self.hparams.append(cfg)


def test_train_logs_per_task_success_and_writes_final_checkpoint(tmp_path: Path) -> None:
    logger = RecordingLogger()
    trainer = Trainer(_cfg(tmp_path, "max_iterations=3"), env=_env(), logger=logger)
    assert trainer.num_minibatches == 2 and trainer.frames_per_batch == 96
    history = trainer.train()
    assert len(history) == 3 and trainer.iteration == 3 and trainer.frames == 3 * 96
    assert trainer.updates == 3 * 2 * 2 and trainer.skipped_updates == 0
    last = history[-1]
    for name in ("task0", "task1", "task2"):
        assert 0.0 <= last[f"success/{name}"] <= 1.0
        assert f"return/{name}" in last
    assert last["success/mean"] == pytest.approx(sum(last[f"success/task{i}"] for i in range(3)) / 3)
    for key in ("frames", "fps", "loss/objective", "loss/critic", "loss/entropy", "loss/bounds", "train/kl", "train/lr"):
        assert key in last and math.isfinite(last[key]), key
    # success window = pooled successes / episodes over the last iterations
    per_task = trainer.window.per_task()
    assert per_task["episodes"].sum() > 0
    assert len(logger.hparams) == 1 and [s for _, s in logger.metrics] == [96, 192, 288]
    assert "success/task1" in logger.metrics[-1][0]
    table = trainer.success_table()
    assert all(name in table for name in ("task0", "task1", "task2", "mean"))
    assert (tmp_path / "ckpt" / "final.pt").is_file() and (tmp_path / "ckpt" / "last.pt").is_file()


def test_resume_continues_with_identical_counters_parameters_and_losses(tmp_path: Path) -> None:
    full = Trainer(_cfg(tmp_path, "checkpoint.every=2"), env=_env())
    full_history = full.train()
    assert (tmp_path / "ckpt" / "ckpt_000002.pt").is_file()

    resumed = Trainer(
        _cfg(tmp_path, f"resume={tmp_path / 'ckpt' / 'ckpt_000002.pt'}", f"checkpoint.dir={tmp_path / 'ckpt2'}"),
        env=_env(),
    )
    assert (resumed.iteration, resumed.frames, resumed.updates) == (2, 2 * 96, 2 * 4)
    resumed_history = resumed.train()
    assert len(resumed_history) == 2
    for a, b in zip(full_history[2:], resumed_history):
        for key in a:
            if key not in TIMING_KEYS:
                assert a[key] == b[key] or (math.isnan(a[key]) and math.isnan(b[key])), key
    assert (resumed.iteration, resumed.frames, resumed.updates) == (full.iteration, full.frames, full.updates)
    for key, value in _params(full).items():
        assert torch.equal(value, _params(resumed)[key]), key
    torch.testing.assert_close(resumed.obs_norm.stats.mean, full.obs_norm.stats.mean, rtol=0, atol=0)
    torch.testing.assert_close(resumed.loss.value_norm.var, full.loss.value_norm.var, rtol=0, atol=0)


def test_resume_refuses_a_different_configuration(tmp_path: Path) -> None:
    Trainer(_cfg(tmp_path, "max_iterations=1"), env=_env()).train()
    with pytest.raises(ValueError, match="loss.horizon"):
        Trainer(_cfg(tmp_path, "loss.horizon=4", f"resume={tmp_path / 'ckpt' / 'final.pt'}"), env=_env())


def test_resume_refuses_another_reward_version_and_logs_it(tmp_path: Path) -> None:
    logger = RecordingLogger()
    paper = _env()
    paper.reward_version = "paper"
    Trainer(_cfg(tmp_path, "max_iterations=1"), env=paper, logger=logger).train()
    assert logger.hparams[0]["env_info"]["reward_version"] == "paper"
    assert load_checkpoint(tmp_path / "ckpt" / "final.pt")["env_info"]["reward_version"] == "paper"
    v2 = _env()
    v2.reward_version = "v2"
    with pytest.raises(ValueError, match="reward_version: checkpoint='paper' current='v2'"):
        Trainer(_cfg(tmp_path, f"resume={tmp_path / 'ckpt' / 'final.pt'}"), env=v2)


def test_non_finite_updates_are_skipped_and_counted(tmp_path: Path) -> None:
    # the reward of env 0 is NaN at step 10, i.e. in the second iteration (horizon 8)
    trainer = Trainer(_cfg(tmp_path, "max_iterations=3"), env=_env(nan_reward_at_step=10))
    trainer.train_iteration()
    p1, opt1 = _params(trainer), trainer.optimizer.state_dict()["state"][0]["step"].clone()
    with pytest.warns(RuntimeWarning, match="skipped"):
        m2 = trainer.train_iteration()
    assert m2["train/skipped_updates"] == 4 and trainer.skipped_updates == 4
    for key, value in _params(trainer).items():  # all updates skipped: parameters and Adam state untouched
        assert torch.equal(value, p1[key]), key
    assert torch.equal(trainer.optimizer.state_dict()["state"][0]["step"], opt1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        m3 = trainer.train_iteration()
    assert m3["train/skipped_updates"] == 0 and trainer.updates == 8
    assert all(torch.isfinite(v).all() for v in _params(trainer).values())
    assert torch.isfinite(trainer.loss.value_norm.mean).all() and torch.isfinite(trainer.obs_norm.stats.var).all()
    assert any(not torch.equal(v, p1[k]) for k, v in _params(trainer).items())


def test_repeated_non_finite_iterations_abort(tmp_path: Path) -> None:
    trainer = Trainer(_cfg(tmp_path, "max_nonfinite_iterations=1"), env=_env(nan_reward_at_step=10))
    with pytest.raises(RuntimeError, match="non-finite"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        trainer.train()
    assert trainer.iteration == 2


def test_adaptive_learning_rate_follows_kl(tmp_path: Path) -> None:
    up = Trainer(_cfg(tmp_path, "loss.lr_schedule=adaptive", "loss.kl_threshold=100.0"), env=_env())
    up.train_iteration()
    assert float(up.optimizer.param_groups[0]["lr"]) == pytest.approx(5e-4 * 1.5**4, rel=1e-5)
    down = Trainer(_cfg(tmp_path, "loss.lr_schedule=adaptive", "loss.kl_threshold=1e-12"), env=_env())
    down.train_iteration()
    assert float(down.optimizer.param_groups[0]["lr"]) == pytest.approx(5e-4 / 1.5**4, rel=1e-5)


def test_grpo_trainer_runs(tmp_path: Path) -> None:
    trainer = Trainer(_cfg(tmp_path, "loss=grpo", "loss.horizon=6", "loss.minibatch_size=36", "max_iterations=2"), env=_env())
    history = trainer.train()
    assert trainer.critic is None and "loss/critic" not in history[-1]
    assert trainer.frames == 2 * 72 and math.isfinite(history[-1]["loss/objective"])


def test_config_errors_name_valid_choices(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="valid choices"):
        Trainer(_cfg(tmp_path, "loss.name=sac"), env=_env())
    with pytest.raises(ValueError, match="must divide"):
        Trainer(_cfg(tmp_path, "loss.minibatch_size=50"), env=_env())
    with pytest.raises(ValueError, match="valid choices"):
        Trainer(_cfg(tmp_path, "loss.lr_schedule=cosine"), env=_env())
    with pytest.raises(ValueError, match="needs a CUDA device"):
        Trainer(_cfg(tmp_path, "cudagraph_update=true"), env=_env())


def test_checkpoint_file_is_atomic_and_versioned(tmp_path: Path) -> None:
    path = save_checkpoint(tmp_path / "c.pt", {"version": 1, "x": torch.arange(3)})
    assert [p.name for p in tmp_path.iterdir()] == ["c.pt"]
    assert torch.equal(load_checkpoint(path)["x"], torch.arange(3))
    save_checkpoint(tmp_path / "bad.pt", {"version": 99})
    with pytest.raises(ValueError, match="version"):
        load_checkpoint(tmp_path / "bad.pt")


def test_cpu_default_overrides() -> None:
    from mtbench.trainer.run import cpu_default_overrides

    assert cpu_default_overrides([], cuda_available=False) == ["env=cpu_small"]
    assert cpu_default_overrides(["loss=grpo"], cuda_available=False) == ["env=cpu_small"]
    assert cpu_default_overrides([], cuda_available=True) == []
    assert cpu_default_overrides(["device=cpu"], cuda_available=True) == ["env=cpu_small"]
    assert cpu_default_overrides(["env=mt10_rand"], cuda_available=False) == []
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        cfg = compose("config", overrides=["env=cpu_small"])
    assert list(cfg.env.name) == ["reach", "drawer_close", "button_press_topdown"]
    assert cfg.loss.minibatch_size == 384 and cfg.max_iterations == 100
    assert (cfg.env.num_envs * cfg.loss.horizon) % cfg.loss.minibatch_size == 0
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        grpo = compose("config", overrides=["env=mt10_rand", "loss=grpo"])
    assert (grpo.env.num_envs, grpo.loss.horizon, grpo.loss.minibatch_size, grpo.max_iterations) == (4096, 150, 38400, 1908)


def test_run_front_door_logs_to_mcap_and_resume_appends(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from mtbench.logging import read_hparams, read_scalars
    from mtbench.trainer.run import run

    overrides = ["max_iterations=2", "checkpoint.every=1", f"logging.log_dir={tmp_path / 'runs'}", "logging.exp_name=t"]
    trainer = run(_cfg(tmp_path, *overrides), env=_env())
    out = capsys.readouterr().out
    assert "Per-task success" in out and "task2" in out and trainer.iteration == 2
    resumed = run(_cfg(tmp_path, *overrides, "max_iterations=3", f"resume={tmp_path / 'ckpt' / 'ckpt_000002.pt'}"), env=_env())
    assert resumed.iteration == 3
    scalars = read_scalars(tmp_path / "runs")
    assert [step for step, _ in scalars["frames"]] == [96, 192, 288]
    assert "success/mean" in scalars and "success/task0" in scalars and "loss/critic" in scalars
    assert read_hparams(tmp_path / "runs")["loss.name"] == "ppo"


@pytest.mark.parametrize("grad", ["pcgrad", "cagrad", "famo", "none"])
def test_gradient_methods_plug_into_the_trainer(tmp_path: Path, grad: str) -> None:
    trainer = Trainer(_cfg(tmp_path, f"grad={grad}", "grad.diagnostics_every=1", "max_iterations=1"), env=_env())
    assert trainer.update_module is not trainer.loss  # diagnostics_every > 0 wraps even grad=none
    metrics = trainer.train_iteration()
    assert metrics["train/skipped_updates"] == 0 and math.isfinite(metrics["loss/critic"])
    assert -1.0 <= metrics["train/grad_cos_critic_mean"] <= 1.0


def test_sigterm_finishes_the_iteration_checkpoints_and_resume_continues(tmp_path: Path) -> None:
    """A SIGTERM in the middle of a run loses nothing: the run stops after the iteration in flight, writes a
    checkpoint, and a resumed run continues from exactly there."""
    import os
    import signal

    class KillAtIteration2(RecordingLogger):
        def log_metrics(self, metrics, step=None):
            super().log_metrics(metrics, step)
            if len(self.metrics) == 2:
                os.kill(os.getpid(), signal.SIGTERM)

    trainer = Trainer(_cfg(tmp_path, "max_iterations=5"), env=_env(), logger=KillAtIteration2())
    history = trainer.train()
    assert len(history) == 2 and trainer.iteration == 2
    ckpt = tmp_path / "ckpt" / "ckpt_000002.pt"
    assert ckpt.exists() and not (tmp_path / "ckpt" / "final.pt").exists()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # handler restored
    resumed = Trainer(_cfg(tmp_path, "max_iterations=5", f"resume={ckpt}"), env=_env())
    assert resumed.iteration == 2 and resumed.frames == trainer.frames
    assert len(resumed.train()) == 3 and resumed.iteration == 5
