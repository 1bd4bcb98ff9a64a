"""Parkour training (issue "Parkour II"): the automatic flat pre-training stage (selection, key, reuse, weights),
the Go1 arch presets chosen for Parkour envs, the curriculum's levels in the success window, resuming a fine-tuning
run, every architecture and gradient method on a tiny Parkour grid, and the headline command on the CPU."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir

from cpu_runs import assert_same_metrics, compose_config
from mtbench.envs.parkour.observation import SLICES
from mtbench.trainer import build_trainer
from mtbench.trainer.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from mtbench.trainer.hooks import Checkpointer
from mtbench.trainer.metrics import EpisodeStatsWindow
from mtbench.trainer.pretraining import (
    flat_stage_config,
    load_pretrained,
    needs_flat_stage,
    pretrain_flat,
    stage_directory,
    stage_key,
)
from mtbench.trainer.rollout import base_env
from mtbench.trainer.run import parkour_arch_overrides, train_stage

ROOT = Path(__file__).resolve().parents[1]
CONF = str(ROOT / "conf")
# the documented tiny CPU grid (docs/parkour.md): 42 worlds (2 per column), 2 difficulty rows
TINY = ["env.num_envs=42", "env.overrides.num_rows=2"]


def _cfg(tmp_path: Path, *overrides: str):
    base = ["device=cpu", "torch_threads=1", "loss.horizon=8", "max_iterations=1", "pretrain.iterations=1",
            f"pretrain.dir={tmp_path / 'pretrained'}", f"checkpoint.dir={tmp_path / 'ckpt'}", "checkpoint.every=0",
            "logging.progress=none", "logging.logger=none", f"logging.log_dir={tmp_path / 'runs'}"]
    return compose_config([*base, *TINY, *overrides])


# ---------------------------------------------------------------------------------------------- stage selection
@pytest.mark.parametrize(
    ("overrides", "expected"),
    [
        (["env=parkour_hard_cl"], True),
        (["env=parkour_easy"], True),
        (["env=parkour_hard"], True),
        (["env=parkour_flat"], False),  # the stage itself
        (["env=mt10_rand"], False),
        (["env=parkour_hard_cl", "pretrain.iterations=0"], False),
        (["env=parkour_hard_cl", "resume=/some/run/checkpoints/last.pt"], False),  # a resumed run has its weights
        (["env=parkour_hard_cl", "env.name=[flat,balance_beam]"], True),  # a terrain list is a Parkour env
    ],
)
def test_flat_stage_selection(tmp_path: Path, overrides: list[str], expected: bool) -> None:
    cfg = compose_config(overrides)
    assert needs_flat_stage(cfg) is expected


def test_given_pretrained_weights_skip_the_stage(tmp_path: Path) -> None:
    ckpt = tmp_path / "w.pt"
    ckpt.write_bytes(b"")
    cfg = _cfg(tmp_path, "env=parkour_hard_cl", f"pretrained={ckpt}")
    assert not needs_flat_stage(cfg)


def test_stage_config_and_key(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cfg = _cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour", "grad=pcgrad", "seed=7", "max_iterations=9",
               "+env.overrides.curriculum=true")
    stage = flat_stage_config(cfg)
    assert stage.env.name == "parkour_flat" and stage.env.num_envs == 42
    # the grid and the collision set kept, the fine-tuning's curriculum dropped
    assert dict(stage.env.overrides) == {"num_rows": 2, "terrain_collision": "all", "robot_inertia": "menagerie",
                                         "robot_armature": None, "robot_integrator": "euler",
                                         "robot_contact_timeconst": 0.01, "robot_collision_pieces": 1}
    assert stage.grad.name == "none"  # gradient methods start from the plain architecture's weights
    assert stage.max_iterations == 1 and stage.total_frames is None and stage.seed == 0
    key = stage_key(stage)
    # the gradient method, the run's setting, seed and length do not change the stage, nor the sigma that the
    # fine-tuning sets after loading it (the stage itself trains from a fresh policy)
    for other in (["grad=none", "seed=1"], ["env=parkour_easy", "grad=famo"], ["max_iterations=100"],
                  ["pretrained_log_std=0"]):
        same = _cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour", *other)
        assert stage_key(flat_stage_config(same)) == key, other
        assert flat_stage_config(same).pretrained_log_std is None, other
    # what shapes the weights does
    for other in (["arch=mlp_parkour"], ["arch.kwargs.hidden_dim=128"], ["loss.lr=1e-3"], ["pretrain.iterations=2"],
                  ["loss.clip_actions=false"],
                  ["pretrain.seed=1"], ["pretrain.num_envs=84"], ["env.overrides.num_rows=3"]):
        differs = _cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour", *other)
        assert stage_key(flat_stage_config(differs)) != key, other
    # and so does the inertial model (the flat stage trains with it); the default's key is the one it had before
    # robot_inertia existed (the override only enters through robot.model_version)
    urdf = flat_stage_config(_cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour",
                                  "env.overrides.robot_inertia=urdf"))
    assert urdf.env.overrides.robot_inertia == "urdf" and stage_key(urdf) != key
    without = flat_stage_config(cfg)
    for name in ("robot_inertia", "robot_armature", "robot_integrator", "robot_contact_timeconst",
                 "robot_collision_pieces"):
        del without.env.overrides[name]
    assert stage_key(without) == key
    # the armature and the integrator too; the default armature named explicitly is the default model
    keys = {key}
    for other in (["env.overrides.robot_armature=0.0"], ["env.overrides.robot_integrator=implicitfast"],
                  ["env.overrides.robot_armature=0.0", "env.overrides.robot_integrator=implicitfast"],
                  ["env.overrides.robot_inertia=urdf", "env.overrides.robot_armature=0.0",
                   "env.overrides.robot_integrator=implicitfast"], ["env.overrides.robot_contact_timeconst=null"],
                  ["env.overrides.robot_collision_pieces=4"]):
        keys.add(stage_key(flat_stage_config(_cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour", *other))))
    assert len(keys) == 7
    for named in ("env.overrides.robot_armature=0.01", "env.overrides.robot_contact_timeconst=0.01",
                  "env.overrides.robot_collision_pieces=1"):
        assert stage_key(flat_stage_config(_cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour", named))) == key
    # and so does a new robot model (a physics change)
    monkeypatch.setattr("mtbench.envs.parkour.robot.MODEL_VERSION", "another-model")
    assert stage_key(stage) != key
    monkeypatch.undo()
    assert stage_directory(cfg).parent == tmp_path / "pretrained"
    assert stage_directory(cfg).name == f"moore-{key[:12]}"


# ---------------------------------------------------------------------------------------------- presets
def test_parkour_envs_get_the_go1_arch_presets() -> None:
    args, note = parkour_arch_overrides(["env=parkour_hard_cl", "loss=ppo", "arch=moore"])
    assert args == ["env=parkour_hard_cl", "loss=ppo", "arch=moore_parkour"] and "moore_parkour" in note
    assert parkour_arch_overrides(["env=parkour_easy"])[0] == ["env=parkour_easy", "arch=mlp_parkour"]
    assert parkour_arch_overrides(["env=parkour_easy", "arch=paco_parkour"]) == (
        ["env=parkour_easy", "arch=paco_parkour"], None)
    assert parkour_arch_overrides(["env=parkour_easy", "arch=care"]) == (["env=parkour_easy", "arch=care"], None)
    assert parkour_arch_overrides(["env=mt10_rand", "arch=moore"]) == (["env=mt10_rand", "arch=moore"], None)


@pytest.mark.parametrize(
    ("arch", "log_std", "entropy"),
    [("mlp_parkour", 0.0, 0.001), ("multihead_parkour", 0.0, 0.001), ("moore_parkour", 0.0, 0.005),
     ("paco_parkour", 0.0, 0.005), ("soft_modularization_parkour", 0.0, 0.005), ("care", 0.0, 0.001)],
)
def test_go1_ppo_settings_per_architecture(arch: str, log_std: float, entropy: float) -> None:
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        cfg = compose("config", overrides=["env=parkour_hard_cl", f"arch={arch}"])
        given = compose("config", overrides=["env=parkour_hard_cl", f"arch={arch}", "loss.entropy_coeff=0.02"])
    assert cfg.loss.log_std_init == log_std and cfg.loss.entropy_coeff == entropy
    assert not cfg.loss.normalize_input and not cfg.loss.normalize_value and cfg.loss.lr_schedule == "adaptive"
    assert given.loss.entropy_coeff == 0.02  # the command line wins


# ---------------------------------------------------------------------------------------------- success window
def test_window_reports_levels_and_hides_tasks_without_worlds() -> None:
    names = ["a", "b", "c"]
    window = EpisodeStatsWindow(names, window=2, metric="progress", active=[True, False, True])
    zeros = torch.zeros(3)
    window.push({"episodes": torch.tensor([2.0, 0.0, 1.0]), "success": torch.tensor([1.0, 0.0, 0.5]),
                 "return": zeros, "length": zeros, "terrain_level": torch.tensor([6.0, 0.0, 1.0]),
                 "max_terrain_level": torch.tensor([4.0, -1.0, 1.0])})
    window.push({"episodes": torch.tensor([2.0, 0.0, 0.0]), "success": torch.tensor([2.0, 0.0, 0.0]),
                 "return": zeros, "length": zeros, "terrain_level": torch.tensor([10.0, 0.0, 0.0]),
                 "max_terrain_level": torch.tensor([5.0, -1.0, -1.0])})
    summary = window.summary()
    assert summary["success/a"] == 0.75 and summary["success/c"] == 0.5
    assert summary["terrain_level/a"] == 4.0 and summary["terrain_level_max/a"] == 5.0
    assert summary["terrain_level/c"] == 1.0 and summary["terrain_level_max/c"] == 1.0
    assert summary["terrain_level/mean"] == 2.5 and "success/b" not in summary
    table = window.table()
    assert table.splitlines()[0].split()[:2] == ["task", "progress"] and "max level" in table
    assert not any(line.startswith("b ") for line in table.splitlines())
    assert "1 task slot without worlds" in table
    restored = EpisodeStatsWindow(names, window=2, metric="progress")
    restored.load_state_dict(window.state_dict())
    assert restored.summary() == summary
    fixed_rows = EpisodeStatsWindow(names, window=2, levels=False)  # levels that are not a curriculum
    fixed_rows.push({"episodes": torch.ones(3), "success": zeros, "return": zeros, "length": zeros,
                     "terrain_level": torch.ones(3), "max_terrain_level": torch.ones(3)})
    assert "terrain_level/mean" not in fixed_rows.summary() and "level" not in fixed_rows.table()


def test_window_reports_how_the_episodes_ended() -> None:
    """``end_<reason>`` counts become shares of the finished episodes over the window (per task and the mean over
    tasks with episodes), a second table, and survive a state round trip; a state saved without them loads."""
    names = ["a", "b"]
    window = EpisodeStatsWindow(names, window=2, metric="progress")
    zeros = torch.zeros(2)
    window.push({"episodes": torch.tensor([4.0, 0.0]), "success": zeros, "return": zeros, "length": zeros,
                 "end_time": torch.tensor([1.0, 0.0]), "end_roll": torch.tensor([3.0, 0.0])})
    window.push({"episodes": torch.tensor([4.0, 2.0]), "success": zeros, "return": zeros, "length": zeros,
                 "end_time": torch.tensor([0.0, 0.0]), "end_roll": torch.tensor([4.0, 2.0])})
    summary = window.summary()
    assert summary["end_time/a"] == 1 / 8 and summary["end_roll/a"] == 7 / 8 and summary["end_roll/b"] == 1.0
    assert summary["end_roll/mean"] == (7 / 8 + 1.0) / 2 and summary["end_time/mean"] == 1 / 16
    ended = window.table().split("\n\n")[1].splitlines()
    assert ended[0].split() == ["ended", "by", "time", "roll"]
    assert ended[2].split() == ["a", "12.5%", "87.5%"] and ended[3].split() == ["b", "0.0%", "100.0%"]
    window.push({"episodes": torch.tensor([0.0, 2.0]), "success": zeros, "return": zeros, "length": zeros,
                 "end_time": torch.tensor([0.0, 2.0]), "end_roll": zeros})  # the first push leaves the window
    assert window.summary()["end_time/b"] == 0.5 and window.summary()["end_roll/a"] == 1.0
    restored = EpisodeStatsWindow(names, window=2, metric="progress")
    restored.load_state_dict(window.state_dict())
    assert restored.summary() == window.summary()
    before = {k: v for k, v in window.state_dict().items() if k not in ("end_keys", "ends")}
    old = EpisodeStatsWindow(names, window=2, metric="progress")
    old.load_state_dict(before)  # a checkpoint from before the end reasons
    assert not any(k.startswith("end_") for k in old.summary()) and "ended by" not in old.table()


# ---------------------------------------------------------------------------------------------- stages, weights
@pytest.fixture(scope="module")
def stage(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """One flat pre-training of mlp_parkour on the tiny grid (1 iteration): (tmp dir, final checkpoint)."""
    tmp = tmp_path_factory.mktemp("stage")
    cfg = _cfg(tmp, "env=parkour_hard_cl", "arch=mlp_parkour")
    lines: list[str] = []
    path = pretrain_flat(cfg, train_stage, echo=lines.append)
    assert path is not None and path.is_file() and "no checkpoint for this architecture yet" in lines[0]
    return tmp, path


def test_stage_is_trained_once_and_reused(stage: tuple[Path, Path]) -> None:
    tmp, final = stage
    saved = load_checkpoint(final)
    assert saved["config"]["env"]["name"] == "parkour_flat" and saved["counters"]["iteration"] == 1
    assert (final.parent.parent / "stage.json").is_file()
    mtime = final.stat().st_mtime_ns
    lines: list[str] = []
    # another gradient method, setting and seed of the same architecture: the same stage, not trained again
    cfg = _cfg(tmp, "env=parkour_easy", "arch=mlp_parkour", "grad=pcgrad", "seed=3")
    assert pretrain_flat(cfg, lambda c: pytest.fail("trained again"), echo=lines.append) == final
    assert "reusing" in lines[0] and final.stat().st_mtime_ns == mtime


def test_fine_tuning_starts_from_the_stage_weights_only(stage: tuple[Path, Path]) -> None:
    tmp, final = stage
    cfg = _cfg(tmp, "env=parkour_hard_cl", "arch=mlp_parkour", "loss.entropy_coeff=0.02", f"pretrained={final}")
    trainer = build_trainer(cfg)
    saved = load_checkpoint(final)["loss"]
    current = trainer.loss.state_dict()
    networks = [k for k in current if k.split(".", 1)[0].endswith("_network_params")]
    assert any(k.startswith("actor_network_params") for k in networks)
    assert any(k.startswith("critic_network_params") for k in networks)
    for key in networks:
        torch.testing.assert_close(current[key], saved[key], rtol=0, atol=0)
    assert float(current["entropy_coeff"]) == pytest.approx(0.02)  # this run's coefficient, not the stage's
    assert trainer.iteration == 0 and trainer.frames == 0
    # the weights are the trained ones, not a fresh initialisation
    fresh = build_trainer(_cfg(tmp, "env=parkour_hard_cl", "arch=mlp_parkour"))
    assert any(not torch.equal(fresh.loss.state_dict()[k], current[k]) for k in networks)
    trainer.env.close()
    fresh.env.close()


def test_pretrained_log_std_resets_the_exploration_noise_only(stage: tuple[Path, Path]) -> None:
    tmp, final = stage
    cfg = _cfg(tmp, "env=parkour_hard_cl", "arch=mlp_parkour", f"pretrained={final}", "pretrained_log_std=-1.5")
    trainer = build_trainer(cfg)
    saved = load_checkpoint(final)["loss"]
    current = trainer.loss.state_dict()
    networks = [k for k in current if k.split(".", 1)[0].endswith("_network_params")]
    std_keys = [k for k in networks if k.endswith(".log_std")]
    assert std_keys == ["actor_network_params.module.0.module.log_std"]
    assert torch.equal(current[std_keys[0]], torch.full((12,), -1.5))
    assert not torch.equal(saved[std_keys[0]], current[std_keys[0]])
    for key in networks:
        if key not in std_keys:
            torch.testing.assert_close(current[key], saved[key], rtol=0, atol=0)
    # the policy samples with that noise: scale = exp(-1.5) for every joint
    td = trainer.env.reset()
    dist = trainer.policy.get_dist(td)
    torch.testing.assert_close(dist.base_dist.scale if hasattr(dist, "base_dist") else dist.scale,
                               torch.full((42, 12), math.exp(-1.5)))
    trainer.env.close()


@pytest.mark.parametrize("value", [-5.5, 2.5, "big", float("nan")])
def test_pretrained_log_std_out_of_range_is_one_clear_error(tmp_path: Path, value: object) -> None:
    from mtbench.trainer.config import check_config

    cfg = _cfg(tmp_path, "env=parkour_hard_cl")
    cfg.pretrained_log_std = value
    with pytest.raises(ValueError, match=r"pretrained_log_std must be a number in \[-5.0, 2.0\] or null"):
        check_config(cfg)


def test_pretrained_of_another_architecture_is_refused(stage: tuple[Path, Path], tmp_path: Path) -> None:
    _, final = stage
    trainer = build_trainer(_cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour"))
    with pytest.raises(ValueError, match=r"pretrained=.*do not fit this run's"):
        load_pretrained(trainer, final)
    with pytest.raises(ValueError, match=r"pretrained=.*does not exist"):
        build_trainer(_cfg(tmp_path, "env=parkour_hard_cl", f"pretrained={tmp_path / 'missing.pt'}"))
    trainer.env.close()


def test_resuming_mid_fine_tuning_continues_exactly(stage: tuple[Path, Path], tmp_path: Path) -> None:
    _, final = stage
    common = ["env=parkour_hard_cl", "arch=mlp_parkour", f"pretrained={final}", "checkpoint.every=1"]
    whole = build_trainer(_cfg(tmp_path / "whole", *common, "max_iterations=3"))
    expected = whole.train()
    whole.env.close()
    first = build_trainer(_cfg(tmp_path / "cut", *common, "max_iterations=3"))
    first.total_iterations = 2  # stop after 2 of the 3 iterations (a kill after the checkpoint of iteration 2)
    first.train()
    first.env.close()
    ckpt = tmp_path / "cut" / "ckpt" / "ckpt_000002.pt"
    # the resumed run does not read the pre-trained weights again: it continues from its own checkpoint
    resumed = build_trainer(_cfg(tmp_path / "cut", *[c for c in common if not c.startswith("pretrained")],
                                 "max_iterations=3", f"resume={ckpt}"))
    assert resumed.iteration == 2
    got = resumed.train()
    resumed.env.close()
    assert len(got) == 1
    a, b = expected[-1], got[-1]
    assert any(k.startswith("terrain_level/") for k in a)
    assert_same_metrics(a, b)
    # a checkpoint written before robot_contact_timeconst existed ran on MuJoCo's soft contacts: resuming it under
    # today's stiffer default is refused with the key named; naming the old physics resumes it
    state = load_checkpoint(ckpt)
    del state["config"]["env"]["overrides"]["robot_contact_timeconst"]
    old = save_checkpoint(tmp_path / "old.pt", state)
    plain = [c for c in common if not c.startswith("pretrained")]
    with pytest.raises(ValueError, match=r"env\.overrides\.robot_contact_timeconst: checkpoint=None current=0\.01"):
        build_trainer(_cfg(tmp_path / "cut", *plain, "max_iterations=3", f"resume={old}"))
    soft = build_trainer(_cfg(tmp_path / "cut", *plain, "max_iterations=3", f"resume={old}",
                              "env.overrides.robot_contact_timeconst=null"))
    assert soft.iteration == 2 and soft.env.scene.robot_contact_timeconst is None
    soft.env.close()
    # the collision pieces too (the checkpoint's per-geom model fields fit only its own); a checkpoint from before
    # the key existed had whole shapes (the default) and resumes as it is
    with pytest.raises(ValueError, match=r"env\.overrides\.robot_collision_pieces: checkpoint=1 current=2"):
        build_trainer(_cfg(tmp_path / "cut", *plain, "max_iterations=3", f"resume={ckpt}",
                           "env.overrides.robot_collision_pieces=2"))
    del state["config"]["env"]["overrides"]["robot_collision_pieces"]
    state["config"]["env"]["overrides"]["robot_contact_timeconst"] = 0.01
    older = save_checkpoint(tmp_path / "older.pt", state)
    whole_shapes = build_trainer(_cfg(tmp_path / "cut", *plain, "max_iterations=3", f"resume={older}"))
    assert whole_shapes.iteration == 2 and whole_shapes.env.scene.robot_collision_pieces == 1
    whole_shapes.env.close()
    # a networks-only checkpoint (docs/results/checkpoints) cannot be resumed; the error says to use pretrained=
    slim = save_checkpoint(tmp_path / "slim.pt", {k: state[k] for k in ("version", "config", "env_info", "counters",
                                                                       "loss", "obs_norm")})
    with pytest.raises(CheckpointError, match=r"holds no optimizer, env, rollout state.*pretrained=.*slim\.pt"):
        build_trainer(_cfg(tmp_path / "cut", *plain, "max_iterations=3", f"resume={slim}"))


# ---------------------------------------------------------------------------------------------- action clipping
@pytest.mark.parametrize(("overrides", "expected"), [
    (["env=parkour_hard_cl"], True), (["env=parkour_easy", "arch=moore"], True), (["env=parkour_flat"], True),
    (["env=parkour_hard"], True), (["env=mt10_rand"], False), (["env=mt10_rand", "loss=grpo"], False)])
def test_parkour_settings_clip_actions_as_mtbench_go1_configs(overrides: list[str], expected: bool) -> None:
    assert compose_config(overrides).loss.clip_actions is expected


@pytest.mark.parametrize(("arch", "kl_threshold"), [("mlp_parkour", 0.008), ("moore_parkour", 0.01),
                                                    ("paco_parkour", 0.008), ("soft_modularization_parkour", 0.008)])
def test_go1_kl_adaptive_lr_as_mtbench(arch: str, kl_threshold: float) -> None:
    """MTBench's Go1 configs: KL-adaptive lr, rl_games schedule_type standard, threshold 0.008 (MOORE 0.01)."""
    loss = compose_config(["env=parkour_hard_cl", f"arch={arch}"]).loss
    assert (loss.lr_schedule, loss.lr_schedule_type, loss.kl_threshold) == ("adaptive", "standard", kl_threshold)


@pytest.mark.parametrize("clip", [True, False])
def test_clipped_actions_reach_the_env_and_the_rollout_keeps_the_raw_sample(tmp_path: Path, clip: bool) -> None:
    """rl_games ``clip_actions`` (MTBench's Go1 configs): the env steps with, and observes as its last action,
    ``clamp(a, -1, 1)``; the rollout keeps the raw sample (whose log-probability the loss uses). Without it the
    env's own +-5 clip applies."""
    cfg = _cfg(tmp_path, "env=parkour_hard_cl", "arch=mlp_parkour", "pretrain.iterations=0",
               f"loss.clip_actions={str(clip).lower()}")
    trainer = build_trainer(cfg)
    env, base = trainer.env, base_env(trainer.env)
    td = env.reset()
    raw = torch.linspace(-3.0, 3.0, 12).expand(42, 12).clone()
    td["action"] = raw
    stepped, _ = env.step_and_maybe_reset(td)
    running = ~stepped["next", "done"].squeeze(-1)  # finished worlds were reset (last action 0)
    assert running.sum() >= 40
    expected = raw.clamp(-1.0, 1.0) if clip else raw
    torch.testing.assert_close(base.last_action[running], expected[running], rtol=0, atol=0)
    observed = stepped["next", "observation"][:, SLICES["last_action"]]
    torch.testing.assert_close(observed[running], expected[running], rtol=0, atol=0)
    assert torch.equal(stepped["action"], raw)
    trainer.env.close()


# ---------------------------------------------------------------------------------------------- every arch / grad
@pytest.mark.parametrize(
    ("arch", "grad"),
    [("mlp_parkour", "none"), ("moore_parkour", "none"), ("multihead_parkour", "none"), ("paco_parkour", "none"),
     ("soft_modularization_parkour", "none"), ("care", "none"), ("care_mh", "none"), ("moore_mh", "none"),
     ("mlp_parkour", "pcgrad"), ("mlp_parkour", "cagrad"), ("mlp_parkour", "famo")],
)
def test_every_architecture_and_gradient_method_trains_on_parkour(tmp_path: Path, arch: str, grad: str) -> None:
    cfg = _cfg(tmp_path, "env=parkour_hard_cl", f"arch={arch}", f"grad={grad}", "pretrain.iterations=0",
               "loss.epochs=1")
    with pytest.warns() if arch.startswith("care") else _nothing():  # CARE: no Parkour sentences, learned context
        trainer = build_trainer(cfg)
    (metrics,) = trainer.train()
    trainer.env.close()
    assert trainer.num_tasks == 21 and trainer.window.metric == "progress"
    losses = {k: v for k, v in metrics.items() if k.startswith("loss/")}
    assert losses and all(math.isfinite(v) for v in losses.values())


class _nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> bool:
        return False


# ---------------------------------------------------------------------------------------------- the headline command
def test_headline_command_on_a_tiny_cpu_grid(tmp_path: Path) -> None:
    """``python examples/train.py env=parkour_hard_cl loss=ppo arch=moore`` with the documented tiny-grid override:
    pre-trains on flat ground, fine-tunes on the 21 tasks and prints per-task progress and terrain levels; a second
    run (another gradient method) reuses the pre-training."""
    args = [sys.executable, str(ROOT / "examples" / "train.py"), "env=parkour_hard_cl", "loss=ppo", "arch=moore",
            *TINY, "max_iterations=2", "pretrain.iterations=2", "torch_threads=1", "logging.progress=line",
            f"hydra.run.dir={tmp_path / 'run'}", f"logging.log_dir={tmp_path / 'runs'}"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    text = out.stdout
    assert "arch=moore -> arch=moore_parkour" in text
    assert "== stage 1/2: flat-ground pre-training" in text and "== stage 2/2: parkour_hard_cl" in text
    assert "Per-task progress over the last" in text and "max level" in text
    for task in ("jump_on_and_off_box", "balance_beam", "flat"):
        assert task in text.split("== stage 2/2")[1]
    stage_dirs = list((tmp_path / "runs" / "pretrained").glob("moore-*"))
    assert len(stage_dirs) == 1 and (stage_dirs[0] / "checkpoints" / "final.pt").is_file()
    final = load_checkpoint(tmp_path / "run" / "checkpoints" / "final.pt")
    assert final["config"]["pretrained"] == str(stage_dirs[0] / "checkpoints" / "final.pt")
    assert final["config"]["arch"]["kwargs"]["num_experts"] == 2  # the Go1 MOORE preset
    again = subprocess.run([*args[:-2], "grad=pcgrad", f"hydra.run.dir={tmp_path / 'run2'}",
                            f"logging.log_dir={tmp_path / 'runs'}"], cwd=tmp_path, env=env, capture_output=True,
                           text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "flat pre-training: reusing" in again.stdout and "Per-task progress" in again.stdout


def test_an_interrupted_stage_continues_from_its_last_checkpoint(tmp_path: Path) -> None:
    cfg = _cfg(tmp_path, "env=parkour_hard_cl", "arch=mlp_parkour", "pretrain.iterations=2", "checkpoint.every=1")

    def stopped_after_one(stage_cfg):
        trainer = build_trainer(stage_cfg)
        trainer.total_iterations = 1  # as if killed after the checkpoint of iteration 1 (no final.pt)
        trainer.get_hook(Checkpointer).save_final = False
        trainer.train()
        trainer.env.close()
        trainer.total_iterations = 2
        return trainer

    lines: list[str] = []
    assert pretrain_flat(cfg, stopped_after_one, echo=lines.append) is None
    assert "stopped at iteration 1/2" in lines[-1]
    final = pretrain_flat(cfg, train_stage, echo=lines.append)
    assert final is not None and "continuing from" in lines[-1] and lines[-1].count("last.pt") == 1
    assert load_checkpoint(final)["counters"]["iteration"] == 2


# ---------------------------------------------------------------------------------------------- evaluation
def test_eval_command_on_a_parkour_moore_checkpoint(tmp_path: Path) -> None:
    """``examples/eval.py`` on a Parkour run (MOORE: its task one-hots are a non-persistent buffer that TorchRL's
    loss keeps): per-task progress for the 21 terrains, deterministic actions clamped to [-1, 1] as in training
    (``loss.clip_actions``, MTBench's Go1 configs; the env's own bounds are +-5); ``video=true`` writes one video per
    terrain, each world on its own tile."""
    from mtbench.evaluation import EvalArgumentError, evaluate, parse_args
    from mtbench.evaluation.video import read_video

    cfg = _cfg(tmp_path, "env=parkour_hard_cl", "arch=moore_parkour", "pretrain.iterations=0",
               "+env.overrides.episode_length=16")
    trainer = build_trainer(cfg)
    trainer.train()
    trainer.env.close()
    ckpt = tmp_path / "ckpt" / "final.pt"
    seen: list[torch.Tensor] = []

    def record(policy) -> None:
        with torch.no_grad():  # large means: the deterministic actions reach the clamp
            for param in policy.actor.parameters():
                param.mul_(30.0)
        forward = policy.forward

        def wrapped(td, deterministic=False):
            action = forward(td, deterministic)
            if deterministic:
                seen.append(action)
            return action
        policy.forward = wrapped

    report = evaluate(parse_args([f"checkpoint={ckpt}", "episodes=1", f"out={tmp_path / 'eval'}"]),
                      policy_hook=record)
    sampled, deterministic = report.results
    assert sampled.metric == "progress" and len(sampled.task_names) == 21
    assert all(n >= 1 for n in deterministic.episodes)
    assert all(0.0 <= p <= 1.0 for p in deterministic.success)
    shares = deterministic.end_shares()  # how the counted episodes ended: one reason each
    assert list(shares) == ["goals", "time", "height", "roll", "pitch", "physics"]
    for i, n in enumerate(deterministic.episodes):
        assert sum(shares[r][i] for r in shares) == pytest.approx(1.0)
    assert "How the counted episodes ended" in report.table and "| height" in report.table
    assert "How the counted episodes ended" in report.markdown.read_text()
    actions = torch.cat(seen)
    assert actions.abs().max() == 1.0  # clamped as in training (clip_actions), not to the env's +-5
    video = evaluate(parse_args([f"checkpoint={ckpt}", "episodes=1", "video=true", "video_frames=4",
                                 "video_size=48x32", "deterministic=true", f"out={tmp_path / 'eval2'}"]))
    assert sorted(video.videos) == sorted(video.info["task_names"]) and len(video.videos) == 21
    clip = read_video(video.videos["box_jump_even"])
    assert clip.shape == (4, 32, 48, 3)
    assert video.frames_png is not None and video.frames_png.is_file()
    with pytest.raises(EvalArgumentError, match=r"video_grid=2 needs 4 worlds per task, the smallest task block has 1"):
        evaluate(parse_args([f"checkpoint={ckpt}", "episodes=1", "video=true", "video_grid=2",
                             f"out={tmp_path / 'eval3'}"]))
    # other terrains and every world on row 0 (the curriculum's start rows limited to 0): two terrains, two worlds each
    rows0 = evaluate(parse_args([f"checkpoint={ckpt}", "episodes=2", "deterministic=true", f"out={tmp_path / 'eval4'}",
                                 "env.name=[box_jump_even,flat]", "env.overrides.curriculum=true",
                                 "env.overrides.max_init_level=0"]))
    (result,) = rows0.results
    assert rows0.info["env"] == ["box_jump_even", "flat"] and rows0.info["num_envs"] == 4
    assert {t: n for t, n in zip(result.task_names, result.episodes) if n} == {"box_jump_even": 2, "flat": 2}
    assert "- env_overrides: `['env.name=[box_jump_even,flat]'" in rows0.markdown.read_text()
