"""Trainer: Hydra config composition, logging, per-task success, hooks, checkpoint/resume exactness (between
iterations and in the middle of a rollout), checksummed checkpoints, NaN guard, progress and CPU-size warning."""

from __future__ import annotations

import ctypes
import io
import math
import os
import signal
import sys
import threading
import time
import warnings
from pathlib import Path
from typing import Any

import pytest
import torch
from tensordict import TensorDict

from cpu_runs import assert_same_metrics, compose_config
from envs_for_tests import SyntheticMTEnv
from mtbench.trainer import (
    Checkpointer,
    NonFiniteGuard,
    ProgressHook,
    Trainer,
    TrainerHook,
    build_trainer,
    observation_norm,
)
from mtbench.trainer.checkpoint import CheckpointError, load_checkpoint, save_checkpoint


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
        f"logging.log_dir={tmp_path / 'runs'}",
    ]
    return compose_config([*base, *overrides])


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
    trainer = build_trainer(_cfg(tmp_path, "max_iterations=3"), env=_env(), logger=logger)
    assert trainer.num_minibatches == 2 and trainer.frames_per_batch == 96
    history = trainer.train()
    assert len(history) == 3 and trainer.iteration == 3 and trainer.frames == 3 * 96
    assert trainer.updates == 3 * 2 * 2 and trainer.get_hook(NonFiniteGuard).skipped_total == 0
    last = history[-1]
    for name in ("task0", "task1", "task2"):
        assert 0.0 <= last[f"success/{name}"] <= 1.0
        assert f"return/{name}" in last
    assert last["success/mean"] == pytest.approx(sum(last[f"success/task{i}"] for i in range(3)) / 3)
    for key in ("frames", "fps", "loss/objective", "loss/critic", "loss/entropy", "loss/bounds", "train/kl", "train/lr",
                "train/skipped_updates"):
        assert key in last and math.isfinite(last[key]), key
    per_task = trainer.window.per_task()  # success window = pooled successes / episodes over the last iterations
    assert per_task["episodes"].sum() > 0
    assert len(logger.hparams) == 1 and [s for _, s in logger.metrics] == [96, 192, 288]
    assert logger.hparams[0]["logging"]["exp_name"] == trainer.config.logging.exp_name
    assert "success/task1" in logger.metrics[-1][0]
    table = trainer.success_table()
    assert all(name in table for name in ("task0", "task1", "task2", "mean"))
    assert (tmp_path / "ckpt" / "final.pt").is_file() and (tmp_path / "ckpt" / "last.pt").is_file()


class Recorder(TrainerHook):
    """Records the order of the hook points."""

    name = "recorder"

    def __init__(self) -> None:
        self.calls: list[str] = []

    def on_train_start(self, trainer: Any) -> None:
        self.calls.append("train_start")

    def on_iteration_start(self, trainer: Any) -> None:
        self.calls.append("iteration_start")

    def on_rollout_step(self, trainer: Any, step: int, horizon: int) -> None:
        self.calls.append(f"step{step}/{horizon}")

    def before_optimizer_step(self, trainer: Any, metrics: Any) -> None:
        self.calls.append("before_step" + ("+skipped" if "skipped" in metrics.keys() else ""))

    def on_update(self, trainer: Any, metrics: Any) -> None:
        self.calls.append("update")

    def on_iteration_end(self, trainer: Any, metrics: dict[str, float]) -> None:
        self.calls.append(f"iteration_end{int(metrics['iteration'])}")

    def on_train_end(self, trainer: Any, stopped: bool) -> None:
        self.calls.append(f"train_end(stopped={stopped})")

    def on_error(self, trainer: Any, error: BaseException) -> None:
        self.calls.append(f"error({type(error).__name__})")


def test_hooks_are_called_at_their_points_in_order(tmp_path: Path) -> None:
    trainer = build_trainer(_cfg(tmp_path, "max_iterations=1", "loss.horizon=2", "loss.minibatch_size=24"), env=_env())
    recorder = Recorder()
    trainer.add_hook(recorder, before=NonFiniteGuard)  # first: sees the metrics before the guard adds "skipped"
    trainer.train()
    updates = ["before_step", "update"] * 2  # 2 epochs x 1 minibatch
    assert recorder.calls == ["train_start", "iteration_start", "step1/2", "step2/2", *updates, "iteration_end1",
                              "train_end(stopped=False)"]
    with pytest.raises(ValueError, match="already registered"):
        trainer.add_hook(Recorder())


def test_resume_continues_with_identical_counters_parameters_and_metrics(tmp_path: Path) -> None:
    full = build_trainer(_cfg(tmp_path, "checkpoint.every=2"), env=_env())
    full_history = full.train()
    assert (tmp_path / "ckpt" / "ckpt_000002.pt").is_file()

    resumed = build_trainer(
        _cfg(tmp_path, f"resume={tmp_path / 'ckpt' / 'ckpt_000002.pt'}", f"checkpoint.dir={tmp_path / 'ckpt2'}"),
        env=_env(),
    )
    assert (resumed.iteration, resumed.frames, resumed.updates) == (2, 2 * 96, 2 * 4)
    resumed_history = resumed.train()
    assert len(resumed_history) == 2
    for a, b in zip(full_history[2:], resumed_history):
        assert_same_metrics(a, b)
    assert (resumed.iteration, resumed.frames, resumed.updates) == (full.iteration, full.frames, full.updates)
    for key, value in _params(full).items():
        assert torch.equal(value, _params(resumed)[key]), key
    assert torch.equal(observation_norm(resumed.env).stats.mean, observation_norm(full.env).stats.mean)
    saved = load_checkpoint(tmp_path / "ckpt" / "ckpt_000002.pt")
    assert torch.equal(saved["obs_norm"]["stats.count"], saved["transforms"][0]["stats.count"])
    assert torch.equal(resumed.loss.value_estimator.value_norm.var, full.loss.value_estimator.value_norm.var)


class StopAt(TrainerHook):
    """Sends this process a signal after env step ``step`` of iteration ``iteration + 1``."""

    name = "stop_at"

    def __init__(self, iteration: int, step: int, signum: int = signal.SIGINT) -> None:
        self.iteration, self.step, self.signum = iteration, step, signum

    def on_rollout_step(self, trainer: Any, step: int, horizon: int) -> None:
        if trainer.iteration == self.iteration and step == self.step:
            os.kill(os.getpid(), self.signum)


def test_first_ctrl_c_stops_after_the_env_step_with_a_checkpoint_that_resumes_exactly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    full_history = build_trainer(_cfg(tmp_path, "max_iterations=4", f"checkpoint.dir={tmp_path / 'full'}"),
                                 env=_env()).train()
    before = signal.getsignal(signal.SIGINT)  # default_int_handler; SIG_IGN in a shell's background job
    stopped = build_trainer(_cfg(tmp_path, "max_iterations=4"), env=_env())
    stopped.add_hook(StopAt(iteration=2, step=3))
    history = stopped.train()
    assert len(history) == 2 and stopped.iteration == 2 and stopped.rollout.steps_done == 3
    ckpt = tmp_path / "ckpt" / "ckpt_000002_step0003.pt"
    assert ckpt.is_file() and not (tmp_path / "ckpt" / "final.pt").exists()
    assert signal.getsignal(signal.SIGINT) is before  # handler restored
    err = capsys.readouterr()
    assert "stopping after the current env step" in err.err and str(ckpt) in err.out
    resumed = build_trainer(_cfg(tmp_path, "max_iterations=4", f"resume={ckpt}"), env=_env())
    assert resumed.rollout.steps_done == 3
    rest = resumed.train()
    assert len(rest) == 2
    for a, b in zip(full_history[2:], rest):
        assert_same_metrics(a, b)


def test_sigterm_between_iterations_checkpoints_and_resume_continues(tmp_path: Path) -> None:
    class KillAtIteration2(RecordingLogger):
        def log_metrics(self, metrics, step=None):
            super().log_metrics(metrics, step)
            if len(self.metrics) == 2:
                os.kill(os.getpid(), signal.SIGTERM)

    trainer = build_trainer(_cfg(tmp_path, "max_iterations=5"), env=_env(), logger=KillAtIteration2())
    history = trainer.train()
    assert len(history) == 2 and trainer.iteration == 2
    ckpt = tmp_path / "ckpt" / "ckpt_000002.pt"
    assert ckpt.exists() and not (tmp_path / "ckpt" / "final.pt").exists()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # handler restored
    resumed = build_trainer(_cfg(tmp_path, "max_iterations=5", f"resume={ckpt}"), env=_env())
    assert resumed.iteration == 2 and resumed.frames == trainer.frames
    assert len(resumed.train()) == 3 and resumed.iteration == 5


@pytest.mark.skipif(not hasattr(signal, "SIGUSR1"), reason="POSIX signal")
def test_sigusr1_stops_at_the_end_of_the_iteration_with_no_partial_rollout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    full_history = build_trainer(_cfg(tmp_path, "max_iterations=4", f"checkpoint.dir={tmp_path / 'full'}"),
                                 env=_env()).train()
    before = signal.getsignal(signal.SIGUSR1)
    stopped = build_trainer(_cfg(tmp_path, "max_iterations=4"), env=_env())
    stopped.add_hook(StopAt(iteration=1, step=3, signum=signal.SIGUSR1))
    history = stopped.train()
    # the rollout of iteration 2 ran to its end and its update was made
    assert len(history) == 2 and stopped.iteration == 2 and stopped.rollout.steps_done == 0
    ckpt = tmp_path / "ckpt" / "ckpt_000002.pt"
    assert ckpt.is_file() and not (tmp_path / "ckpt" / "final.pt").exists()
    assert load_checkpoint(ckpt)["rollout"]["steps"] is None
    assert signal.getsignal(signal.SIGUSR1) is before  # handler restored
    assert "stopping at the end of the current iteration" in capsys.readouterr().err
    assert_same_metrics(full_history[1], history[1])
    resumed = build_trainer(_cfg(tmp_path, "max_iterations=4", f"resume={ckpt}"), env=_env())
    rest = resumed.train()
    assert len(rest) == 2
    for a, b in zip(full_history[2:], rest):
        assert_same_metrics(a, b)


@pytest.mark.skipif(not hasattr(signal, "SIGUSR1"), reason="POSIX signal")
def test_sigterm_after_sigusr1_stops_after_the_env_step() -> None:
    from mtbench.trainer import StopRequest

    stop = StopRequest()
    stop.request(signal.SIGUSR1, at_iteration_end=True)
    assert stop.requested and not stop()  # the rollout goes on; the loop stops between iterations
    stop.request(signal.SIGTERM)
    assert stop()  # now after the current env step
    stop.request(signal.SIGUSR1, at_iteration_end=True)
    assert stop()  # a later SIGUSR1 does not postpone a pending stop


class TakeOverInC(TrainerHook):
    """During env step ``step`` of iteration ``iteration + 1``, sets ``signum``'s disposition to ignore through libc
    (as a C library would: Python's ``signal.getsignal`` still reports the Python handler)."""

    name = "take_over_in_c"

    def __init__(self, iteration: int, step: int, signum: int) -> None:
        self.iteration, self.step, self.signum = iteration, step, signum

    def on_rollout_step(self, trainer: Any, step: int, horizon: int) -> None:
        if trainer.iteration == self.iteration and step == self.step:
            _ignore_in_c(self.signum)


def _ignore_in_c(signum: int) -> None:
    libc = ctypes.CDLL(None, use_errno=True)
    libc.signal.restype = ctypes.c_void_p
    libc.signal.argtypes = [ctypes.c_int, ctypes.c_void_p]
    assert libc.signal(signum, 1) is not None  # 1 = SIG_IGN


def _deliver(signum: int) -> None:
    """Send ``signum`` to this process and give the interpreter a chance to run its Python handler."""
    os.kill(os.getpid(), signum)
    for _ in range(100):
        time.sleep(0.001)


@pytest.mark.skipif(not hasattr(signal, "SIGUSR1") or sys.platform != "linux", reason="POSIX signals, glibc")
def test_stop_request_rearms_a_signal_taken_over_in_c_or_in_python_or_blocked() -> None:
    from mtbench.trainer import StopRequest

    usr1 = signal.SIGUSR1
    before = signal.getsignal(usr1)
    stream = io.StringIO()
    with StopRequest(stream=stream) as stop:
        assert stop.rearm() == []  # nothing changed: nothing said
        _ignore_in_c(usr1)
        _deliver(usr1)
        assert not stop.requested  # the problem: deaf to the signal, and getsignal cannot tell
        assert stop.rearm() == []
        _deliver(usr1)
        assert stop.requested and stop.at_iteration_end
        stop.requested = stop.at_iteration_end = False
        signal.signal(usr1, signal.SIG_IGN)
        assert stop.rearm() == ["SIGUSR1 handler was <Handlers.SIG_IGN: 1>"]
        _deliver(usr1)
        assert stop.requested
        stop.requested = stop.at_iteration_end = False
        signal.pthread_sigmask(signal.SIG_BLOCK, [usr1])
        signal.pthread_kill(threading.main_thread().ident, usr1)  # to this thread, which blocks it
        for _ in range(100):
            time.sleep(0.001)
        assert not stop.requested  # pending
        assert stop.rearm() == ["SIGUSR1 was blocked"]
        for _ in range(100):
            time.sleep(0.001)
        assert stop.requested and usr1 not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    assert signal.getsignal(usr1) is before
    assert "stop signals re-armed (SIGUSR1 handler was <Handlers.SIG_IGN: 1>)" in stream.getvalue()
    assert stop.rearm() == []  # outside the with block: nothing to re-arm


@pytest.mark.skipif(not hasattr(signal, "SIGUSR1") or sys.platform != "linux", reason="POSIX signals, glibc")
def test_sigusr1_is_obeyed_after_a_library_took_it_over_in_an_earlier_iteration(tmp_path: Path) -> None:
    """A C-level takeover during iteration 1 (where a fresh kernel compilation would happen), the signal during
    iteration 2: the trainer re-armed its handlers between the two and stops at the end of iteration 2."""
    stopped = build_trainer(_cfg(tmp_path, "max_iterations=4"), env=_env())
    stopped.add_hook(TakeOverInC(iteration=0, step=1, signum=signal.SIGUSR1))
    stopped.add_hook(StopAt(iteration=1, step=3, signum=signal.SIGUSR1))
    history = stopped.train()
    assert len(history) == 2 and stopped.iteration == 2 and stopped.rollout.steps_done == 0
    assert (tmp_path / "ckpt" / "ckpt_000002.pt").is_file()


def test_resume_refuses_a_different_configuration(tmp_path: Path) -> None:
    build_trainer(_cfg(tmp_path, "max_iterations=1"), env=_env()).train()
    with pytest.raises(ValueError, match="loss.horizon"):
        build_trainer(_cfg(tmp_path, "loss.horizon=4", f"resume={tmp_path / 'ckpt' / 'final.pt'}"), env=_env())


def test_resume_refuses_another_action_clipping(tmp_path: Path) -> None:
    """``loss.clip_actions`` adds an env transform: a run resumes only with the setting it was trained with; a
    checkpoint written before the key existed counts as ``false``."""
    build_trainer(_cfg(tmp_path, "max_iterations=1"), env=_env()).train()
    final = tmp_path / "ckpt" / "final.pt"
    with pytest.raises(ValueError, match=r"loss\.clip_actions: checkpoint=False current=True"):
        build_trainer(_cfg(tmp_path, "loss.clip_actions=true", f"resume={final}"), env=_env())
    state = load_checkpoint(final)
    del state["config"]["loss"]["clip_actions"]  # as written before 2026-11-28
    old = save_checkpoint(tmp_path / "old.pt", state)
    assert build_trainer(_cfg(tmp_path, "max_iterations=2", f"resume={old}"), env=_env()).iteration == 1
    with pytest.raises(ValueError, match=r"loss\.clip_actions: checkpoint=False current=True"):
        build_trainer(_cfg(tmp_path, "loss.clip_actions=true", f"resume={old}"), env=_env())


def test_resume_refuses_another_reward_version_and_logs_it(tmp_path: Path) -> None:
    logger = RecordingLogger()
    paper = _env()
    paper.reward_version = "paper"
    build_trainer(_cfg(tmp_path, "max_iterations=1"), env=paper, logger=logger).train()
    assert logger.hparams[0]["env_info"]["reward_version"] == "paper"
    assert load_checkpoint(tmp_path / "ckpt" / "final.pt")["env_info"]["reward_version"] == "paper"
    v2 = _env()
    v2.reward_version = "v2"
    with pytest.raises(ValueError, match="reward_version: checkpoint='paper' current='v2'"):
        build_trainer(_cfg(tmp_path, f"resume={tmp_path / 'ckpt' / 'final.pt'}"), env=v2)
    # the revision of a version's definition: a v2 checkpoint of an older v2 is refused, also one written before
    # revisions were recorded (the first v2 definition)
    v2.reward_revision = "v2-2026-11-28"
    build_trainer(_cfg(tmp_path / "v2", "max_iterations=1"), env=v2).train()
    final = tmp_path / "v2" / "ckpt" / "final.pt"
    assert load_checkpoint(final)["env_info"]["reward_revision"] == "v2-2026-11-28"
    assert build_trainer(_cfg(tmp_path / "v2", "max_iterations=2", f"resume={final}"), env=v2).iteration == 1
    state = load_checkpoint(final)
    del state["env_info"]["reward_revision"]
    old = save_checkpoint(tmp_path / "old_v2.pt", state)
    with pytest.raises(ValueError, match="reward_revision: checkpoint='v2-2026-11-25' current='v2-2026-11-28'"):
        build_trainer(_cfg(tmp_path / "v2", f"resume={old}"), env=v2)


class OverflowingEnv(SyntheticMTEnv):
    """Reports one non-fatal contact overflow per task per iteration (as ``ParkourEnv``'s ``contact_overflow``)."""

    def pop_episode_stats(self) -> TensorDict:
        stats = super().pop_episode_stats()
        stats["contact_overflow"] = torch.ones(self.num_tasks, device=self.device)
        return stats


def test_contact_overflow_total_is_logged_and_survives_resume(tmp_path: Path) -> None:
    logger = RecordingLogger()
    env = OverflowingEnv([4, 4, 4], max_episode_steps=6, seed=0)
    trainer = build_trainer(_cfg(tmp_path, "max_iterations=2"), env=env, logger=logger)
    trainer.train()
    totals = [m["env/contact_overflow_steps_total"] for m, _ in logger.metrics]
    assert totals == [3.0, 6.0]
    final = tmp_path / "ckpt" / "final.pt"
    assert load_checkpoint(final)["counters"]["contact_overflows"] == 6.0
    resumed = build_trainer(_cfg(tmp_path, "max_iterations=3", f"resume={final}"),
                            env=OverflowingEnv([4, 4, 4], max_episode_steps=6, seed=0), logger=RecordingLogger())
    assert resumed.contact_overflows == 6.0
    resumed.train()
    assert resumed.contact_overflows == 9.0
    # a checkpoint written before the counter existed resumes from 0
    state = load_checkpoint(final)
    del state["counters"]["contact_overflows"]
    old = save_checkpoint(tmp_path / "old.pt", state)
    assert build_trainer(_cfg(tmp_path, "max_iterations=3", f"resume={old}"),
                         env=OverflowingEnv([4, 4, 4], max_episode_steps=6, seed=0)).contact_overflows == 0.0


def test_corrupted_checkpoint_is_refused_naming_the_file(tmp_path: Path) -> None:
    build_trainer(_cfg(tmp_path, "max_iterations=1"), env=_env()).train()
    good = tmp_path / "ckpt" / "final.pt"
    data = bytearray(good.read_bytes())
    assert load_checkpoint(good)["counters"]["iteration"] == 1
    for name, offset in (("adam.pt", -200), ("mid.pt", len(data) // 2)):  # the tail holds the optimizer state
        bad = bytearray(data)
        bad[offset] ^= 0x01
        path = tmp_path / name
        path.write_bytes(bytes(bad))
        with pytest.raises(CheckpointError, match=f"checkpoint {path}: checksum mismatch, the file is corrupted"):
            load_checkpoint(path)
        with pytest.raises(ValueError, match=f"resume={path}: checksum mismatch"):
            build_trainer(_cfg(tmp_path, f"resume={path}"), env=_env())
    path.write_bytes(bytes(data[:-10]))
    with pytest.raises(CheckpointError, match="truncated"):
        load_checkpoint(path)


def test_checkpoint_file_is_atomic_versioned_and_checksummed(tmp_path: Path) -> None:
    path = save_checkpoint(tmp_path / "c.pt", {"version": 2, "x": torch.arange(3)})
    assert [p.name for p in tmp_path.iterdir()] == ["c.pt"]
    assert path.read_bytes().startswith(b"MTBENCH-CHECKPOINT\nsha256=")
    assert torch.equal(load_checkpoint(path)["x"], torch.arange(3))
    save_checkpoint(tmp_path / "bad.pt", {"version": 99})
    with pytest.raises(CheckpointError, match="version"):
        load_checkpoint(tmp_path / "bad.pt")


def test_non_finite_updates_are_skipped_and_counted(tmp_path: Path) -> None:
    # the reward of env 0 is NaN at step 10, i.e. in the second iteration (horizon 8); one minibatch per epoch:
    # every update of that iteration sees the NaN rows
    trainer = build_trainer(_cfg(tmp_path, "max_iterations=3", "loss.minibatch_size=96"),
                            env=_env(nan_reward_at_step=10))
    trainer.train_iteration()
    p1, opt1 = _params(trainer), trainer.optimizer.state_dict()["state"][0]["step"].clone()
    with pytest.warns(RuntimeWarning, match="skipped"):
        m2 = trainer.train_iteration()
    guard = trainer.get_hook(NonFiniteGuard)
    assert m2["train/skipped_updates"] == 2 and guard.skipped_total == 2 and "train/skipped" not in m2
    for key, value in _params(trainer).items():  # all updates skipped: parameters and Adam state untouched
        assert torch.equal(value, p1[key]), key
    assert torch.equal(trainer.optimizer.state_dict()["state"][0]["step"], opt1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        m3 = trainer.train_iteration()
    assert m3["train/skipped_updates"] == 0 and m3["train/skipped_updates_total"] == 2 and trainer.updates == 6
    assert all(torch.isfinite(v).all() for v in _params(trainer).values())
    assert torch.isfinite(trainer.loss.value_estimator.value_norm.mean).all()
    assert torch.isfinite(observation_norm(trainer.env).stats.var).all()
    assert any(not torch.equal(v, p1[k]) for k, v in _params(trainer).items())


def test_repeated_non_finite_iterations_abort(tmp_path: Path) -> None:
    trainer = build_trainer(_cfg(tmp_path, "max_nonfinite_iterations=1", "loss.minibatch_size=96",
                                 "max_iterations=2"), env=_env(nan_reward_at_step=10))
    recorder = Recorder()
    trainer.add_hook(recorder)
    with pytest.raises(RuntimeError, match="non-finite"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        trainer.train()
    assert trainer.iteration == 2 and recorder.calls[-1] == "error(RuntimeError)"
    assert not list((tmp_path / "ckpt").glob("*.pt"))  # no checkpoint of a failed run, even at its last iteration


@pytest.mark.parametrize(("schedule_type", "changes"), [("minibatch", 4), ("standard", 2)])
def test_adaptive_learning_rate_follows_kl(tmp_path: Path, schedule_type: str, changes: int) -> None:
    """One iteration = 2 epochs x 2 minibatches: the lr changes after every update ("minibatch") or after every
    epoch (rl_games "standard")."""
    common = ["loss.lr_schedule=adaptive", f"loss.lr_schedule_type={schedule_type}"]
    up = build_trainer(_cfg(tmp_path, *common, "loss.kl_threshold=100.0"), env=_env())
    up.train_iteration()
    assert float(up.optimizer.param_groups[0]["lr"]) == pytest.approx(5e-4 * 1.5**changes, rel=1e-5)
    down = build_trainer(_cfg(tmp_path, *common, "loss.kl_threshold=1e-12"), env=_env())
    down.train_iteration()
    assert float(down.optimizer.param_groups[0]["lr"]) == pytest.approx(5e-4 / 1.5**changes, rel=1e-5)
    assert (down.updater.kl_reference is not None) is (schedule_type == "standard")
    fixed = build_trainer(_cfg(tmp_path, "loss.kl_threshold=1e-12"), env=_env())
    fixed.train_iteration()
    assert float(fixed.optimizer.param_groups[0]["lr"]) == pytest.approx(5e-4)


def test_grpo_trainer_runs(tmp_path: Path) -> None:
    trainer = build_trainer(
        _cfg(tmp_path, "loss=grpo", "loss.horizon=6", "loss.minibatch_size=36", "max_iterations=2"), env=_env()
    )
    history = trainer.train()
    assert trainer.get_hook(Checkpointer) is not None and "loss/critic" not in history[-1]
    assert trainer.frames == 2 * 72 and math.isfinite(history[-1]["loss/objective"])


def test_progress_inside_long_iterations_and_cpu_size_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trainer = build_trainer(_cfg(tmp_path, "max_iterations=1", "logging.progress=line"), env=_env())
    trainer.get_hook(ProgressHook).inner_every_s = 1e-9  # every env step counts as "long" here
    trainer.train()
    out = capsys.readouterr().out
    assert "iteration 1/1: env step 1/8 (" in out and "iteration 1/1: env step 8/8 (" in out
    assert "[iter 1/1] frames=96" in out
    with pytest.warns(RuntimeWarning, match=r"CPU run with 4,800 worlds x 32 steps per iteration: about 3 min"):
        build_trainer(_cfg(tmp_path, "loss.horizon=32", "loss.minibatch_size=4800"),
                      env=SyntheticMTEnv([1600, 1600, 1600], max_episode_steps=6))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        build_trainer(_cfg(tmp_path), env=_env())  # small: no warning


def test_cpu_default_overrides_and_resume_directory() -> None:
    from mtbench.trainer.run import cpu_default_overrides, resume_dir_overrides

    assert cpu_default_overrides([], cuda_available=False) == ["env=cpu_small"]
    assert cpu_default_overrides(["loss=grpo"], cuda_available=False) == ["env=cpu_small"]
    assert cpu_default_overrides([], cuda_available=True) == []
    # a named config (a paper row) keeps its own env, also on the CPU
    paper = ["--config-dir", "conf/paper/efficiency", "--config-name", "mt10_rand_pqn", "device=cpu"]
    assert cpu_default_overrides(paper, cuda_available=False) == []
    assert cpu_default_overrides(["--config-name=mt10_rand_pqn"], cuda_available=False) == []
    assert cpu_default_overrides(["--config-name", "config"], cuda_available=False) == ["env=cpu_small"]
    assert cpu_default_overrides(["device=cpu"], cuda_available=True) == ["env=cpu_small"]
    assert cpu_default_overrides(["env=mt10_rand"], cuda_available=False) == []
    assert resume_dir_overrides(["resume=/o/d/t/checkpoints/ckpt_000050.pt"]) == ["hydra.run.dir=/o/d/t"]
    assert resume_dir_overrides(["resume=/x/ckpt.pt"]) == ["hydra.run.dir=/x"]
    assert resume_dir_overrides(["resume=/x/ckpt.pt", "hydra.run.dir=/y"]) == []
    assert resume_dir_overrides(["seed=1"]) == []
    cfg = compose_config(["env=cpu_small"])
    assert list(cfg.env.name) == ["reach", "drawer_close", "button_press_topdown"]
    assert cfg.loss.minibatch_size == 384 and cfg.max_iterations == 100
    assert (cfg.env.num_envs * cfg.loss.horizon) % cfg.loss.minibatch_size == 0
    grpo = compose_config(["env=mt10_rand", "loss=grpo"])
    sizes = (grpo.env.num_envs, grpo.loss.horizon, grpo.loss.minibatch_size, grpo.max_iterations)
    assert sizes == (4096, 150, 38400, 1908)


def test_main_argv_keeps_hydra_flags_before_the_overrides(monkeypatch) -> None:
    """Added overrides (the Parkour arch preset, the CPU env, the resume directory) join the user's overrides in one
    run of positional arguments, after Hydra's flags: ``--cfg job`` with a Parkour env used to fail in argparse."""
    import argparse

    from mtbench.trainer.run import main_argv

    monkeypatch.setattr(sys, "argv", ["train.py", "env=parkour_easy", "arch=mlp", "--cfg", "job", "seed=3"])
    argv = main_argv()
    assert argv == ["train.py", "--cfg", "job", "env=parkour_easy", "seed=3", "arch=mlp_parkour"]
    parser = argparse.ArgumentParser()  # Hydra's shape: one flag with a value, then the overrides
    parser.add_argument("--cfg")
    parser.add_argument("overrides", nargs="*")
    assert parser.parse_args(argv[1:]).overrides == ["env=parkour_easy", "seed=3", "arch=mlp_parkour"]
    monkeypatch.setattr(sys, "argv", ["train.py", "--config-name", "x", "resume=/r/checkpoints/last.pt"])
    assert main_argv() == ["train.py", "--config-name", "x", "resume=/r/checkpoints/last.pt", "hydra.run.dir=/r"]


def test_run_front_door_logs_to_mcap_and_resume_appends_in_its_own_directories(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from mtbench.logging import find_segments, read_hparams, read_scalars
    from mtbench.trainer.run import run

    monkeypatch.chdir(tmp_path)  # logging.log_dir null = ./runs, checkpoint.dir null = ./checkpoints (no Hydra)
    overrides = ["max_iterations=2", "checkpoint.every=1", "logging.log_dir=null", "checkpoint.dir=null"]
    trainer = run(_cfg(tmp_path, *overrides), env=_env())
    out = capsys.readouterr().out
    assert "Per-task success" in out and "task2" in out and trainer.iteration == 2
    exp_name = trainer.config.logging.exp_name
    assert trainer.config.logging.log_dir == str(tmp_path / "runs")
    assert (tmp_path / "checkpoints" / "final.pt").is_file()
    other = tmp_path / "elsewhere"
    other.mkdir()
    monkeypatch.chdir(other)  # a resume from another directory still continues the run's log and checkpoints
    ckpt = tmp_path / "checkpoints" / "ckpt_000002.pt"
    resumed = run(_cfg(tmp_path, *overrides, "max_iterations=3", f"resume={ckpt}"), env=_env())
    assert resumed.iteration == 3 and resumed.config.logging.exp_name == exp_name
    assert (tmp_path / "checkpoints" / "ckpt_000003.pt").is_file() and not list(other.iterdir())
    assert [p.name for p in find_segments(tmp_path / "runs")] == [f"{exp_name}.mcap", f"{exp_name}.1.mcap"]
    scalars = read_scalars(tmp_path / "runs")
    assert [step for step, _ in scalars["frames"]] == [96, 192, 288]
    assert "success/mean" in scalars and "success/task0" in scalars and "loss/critic" in scalars
    assert read_hparams(tmp_path / "runs")["loss.name"] == "ppo"


@pytest.mark.parametrize("grad", ["pcgrad", "cagrad", "famo", "none"])
def test_gradient_methods_plug_into_the_trainer(tmp_path: Path, grad: str) -> None:
    trainer = build_trainer(_cfg(tmp_path, f"grad={grad}", "grad.diagnostics_every=1", "max_iterations=1"), env=_env())
    assert trainer.update_module is not trainer.loss  # diagnostics_every > 0 wraps even grad=none
    metrics = trainer.train_iteration()
    assert metrics["train/skipped_updates"] == 0 and math.isfinite(metrics["loss/critic"])
    assert -1.0 <= metrics["train/grad_cos_critic_mean"] <= 1.0


def test_gradient_method_state_resumes_exactly(tmp_path: Path) -> None:
    """PCGrad's task-order generator and FAMO's logits/Adam state are part of the checkpoint."""
    for grad in ("pcgrad", "famo"):
        ck = tmp_path / grad
        full = build_trainer(_cfg(tmp_path, f"grad={grad}", "max_iterations=3", "checkpoint.every=1",
                                  f"checkpoint.dir={ck}"), env=_env()).train()
        resumed = build_trainer(_cfg(tmp_path, f"grad={grad}", "max_iterations=3", f"checkpoint.dir={ck}2",
                                     f"resume={ck / 'ckpt_000001.pt'}"), env=_env()).train()
        for a, b in zip(full[1:], resumed):
            assert_same_metrics(a, b)
