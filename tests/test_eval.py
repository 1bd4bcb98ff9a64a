"""examples/eval.py: checkpoint -> per-task table (sampled and deterministic policy), videos, MCAP log, errors.

A tiny MT-PPO run on the CPU (``env=cpu_small`` with 2 worlds per task, 30-step episodes, one iteration) provides
the checkpoint. Evaluations run 2 episodes per task.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Bounded

from cpu_runs import train_on_cpu
from envs_for_tests import SyntheticMTEnv
from mtbench.evaluation import EvalArgumentError, evaluate, main, parse_args, run_episodes
from mtbench.envs.metaworld import task_class
from mtbench.evaluation.policy import eval_env_config, load_policy, make_eval_env, read_checkpoint
from mtbench.evaluation.render import BACKGROUND, tile
from mtbench.evaluation.run import video_schedule
from mtbench.evaluation.task_slots import TaskSlots, task_slots
from mtbench.evaluation.video import contact_sheet, read_video, write_video
from mtbench.logging import iter_messages, read_scalars
from mtbench.trainer.checkpoint import CHECKPOINT_VERSION, save_checkpoint

TASKS = ["reach", "drawer_close", "button_press_topdown"]
EPISODE_STEPS = 30


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("eval_run")
    overrides = [
        "device=cpu", "env=cpu_small", "env.num_envs=6", f"+env.overrides.episode_length={EPISODE_STEPS}",
        "arch.kwargs.hidden=[32,32]", "loss.horizon=8", "loss.minibatch_size=48", "loss.epochs=1",
        "max_iterations=1", "logging.progress=none", "checkpoint.every=0", f"checkpoint.dir={root / 'ckpt'}",
    ]
    trainer, _ = train_on_cpu(overrides)
    return root / "ckpt" / "final.pt"


@pytest.fixture(scope="module")
def noiseless_video_report(checkpoint: Path, tmp_path_factory: pytest.TempPathFactory):
    """Both evaluations with the policy's log-std set to -30 (sigma ~ 1e-13) and 8-frame videos."""

    def silence(policy) -> None:
        with torch.no_grad():
            policy.head.log_std.fill_(-30.0)

    out = tmp_path_factory.mktemp("eval_video")
    args = parse_args([f"checkpoint={checkpoint}", "episodes=2", "device=cpu", f"out={out}", "video=true",
                       "video_frames=8", "video_size=64x48", "seed=3"])
    return evaluate(args, policy_hook=silence)


def test_main_prints_and_writes_the_per_task_table(checkpoint: Path, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    out = checkpoint.parent / "eval"  # the default output directory
    assert main([f"checkpoint={checkpoint}", "episodes=2", "device=cpu"]) == 0
    printed = capsys.readouterr().out
    table = [line for line in printed.splitlines() if line.startswith("|")]
    assert len(table) == 2 + len(TASKS) + 1  # header, alignment, one row per task, mean
    assert "success (sampled)" in table[0] and "success (deterministic)" in table[0]
    for line, task in zip(table[2:], TASKS):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[0] == task and cells[-1] == "2"  # episodes (the same in both evaluations)
    assert table[-1].startswith("| **mean**")
    report = json.loads((out / "eval.json").read_text())
    assert report["task_names"] == TASKS and report["num_envs"] == 6 and report["episode_steps"] == EPISODE_STEPS
    assert report["seed"] == 43  # default: the training seed (42) + 1, worlds the policy was not trained on
    for mode in ("sampled", "deterministic"):
        per_task = report["evaluations"][mode]["per_task"]
        assert list(per_task) == TASKS
        for row in per_task.values():
            assert row["episodes"] == 2 and row["length"] == EPISODE_STEPS and 0.0 <= row["success"] <= 1.0
    assert all(task in (out / "eval.md").read_text() for task in TASKS)
    scalars = read_scalars(out / "eval.mcap")
    frames = report["frames"]
    for task in TASKS:
        assert scalars[f"success/{task}"][0][0] == frames
        assert scalars[f"deterministic/return/{task}"][0][1] == pytest.approx(
            report["evaluations"]["deterministic"]["per_task"][task]["return"])


def test_long_passes_print_progress_lines(checkpoint: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    import mtbench.evaluation.run as run_module

    monkeypatch.setattr(run_module, "PROGRESS_EVERY_S", 0.0)  # every step counts as long
    assert main([f"checkpoint={checkpoint}", "episodes=2", "device=cpu", f"out={tmp_path}",
                 "deterministic=true"]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines() if ": pass 1/1, step " in line]
    assert len(lines) == EPISODE_STEPS - 1  # steps 1 .. T-1 (step 0 has nothing done yet)
    assert lines[0].startswith("eval | deterministic: pass 1/1, step 1/") and "s left" in lines[-1]
    done = [int(line.split("(")[1].split("%")[0]) for line in lines]
    assert done == sorted(done) and done[-1] == round(100 * (EPISODE_STEPS - 1) / EPISODE_STEPS)


def test_without_sampling_noise_both_evaluations_agree(noiseless_video_report) -> None:
    sampled, deterministic = noiseless_video_report.results
    assert (sampled.mode, deterministic.mode) == ("sampled", "deterministic")
    assert sampled.episodes == deterministic.episodes == [2, 2, 2]
    assert sampled.success == deterministic.success
    assert sampled.returns == pytest.approx(deterministic.returns, rel=1e-5, abs=1e-4)


def test_sampled_and_deterministic_actions_differ_only_by_the_noise(checkpoint: Path) -> None:
    from mtbench.evaluation.policy import load_policy

    class Specs:  # load_policy reads only the env's sizes
        num_tasks = 3
        observation_spec = {"observation": torch.zeros(6, 39 + 3)}
        action_spec = torch.zeros(6, 4)

    policy = load_policy(read_checkpoint(checkpoint), Specs(), torch.device("cpu"))
    torch.manual_seed(0)
    td = TensorDict({"observation": torch.randn(6, 42) * 3, "task_id": torch.tensor([0, 0, 1, 1, 2, 2])},
                    batch_size=[6])
    raw = td["observation"].clone()
    obs = policy.obs_norm.normalize(raw, td["task_id"])
    assert not torch.allclose(obs[:, :39], raw[:, :39])  # the checkpoint's statistics are applied
    loc, _ = policy.head(obs, td["task_id"])
    assert torch.equal(policy(td, deterministic=True), loc.clamp(-1, 1))
    sampled = policy(td, deterministic=False)
    assert not torch.allclose(sampled, loc)  # sigma = exp(log_std) ~ 1 after one iteration
    with torch.no_grad():
        policy.head.log_std.fill_(-30.0)
    assert torch.allclose(policy(td, deterministic=False).clamp(-1, 1), loc.clamp(-1, 1), atol=1e-6)
    assert torch.equal(td["observation"], raw)  # the input is not normalised in place
    # a run that clamped its actions in training (loss.clip_actions, MTBench's Go1 configs) is evaluated clamped to
    # [-1, 1], sampled or not, whatever the env's own bounds
    state = read_checkpoint(checkpoint)
    state["config"]["loss"]["clip_actions"] = True

    class WideSpecs(Specs):
        action_spec = Bounded(-5.0, 5.0, shape=(6, 4))

    clipped = load_policy(state, WideSpecs(), torch.device("cpu"))
    assert float(clipped.action_low) == -1.0 and float(clipped.action_high) == 1.0
    with torch.no_grad():
        clipped.head.log_std.fill_(2.0)
    assert clipped(td, deterministic=False).abs().max() <= 1.0
    assert torch.equal(load_policy(read_checkpoint(checkpoint), WideSpecs(), torch.device("cpu")).action_high,
                       torch.full((4,), 5.0))


def test_videos_have_the_requested_frames_and_show_the_scene(noiseless_video_report) -> None:
    report = noiseless_video_report
    assert list(report.videos) == TASKS
    background = np.array(BACKGROUND[:3]) * 255
    for task, path in report.videos.items():
        assert path.parent == report.out / "videos" and path.stem == task and path.suffix in (".mp4", ".gif")
        frames = read_video(path)
        assert frames.shape[0] == 8 and frames.shape[1:3] == (48, 64)
        assert frames.std() > 20 and len(np.unique(frames.reshape(-1, 3), axis=0)) > 50  # not one colour
        sky = np.abs(frames.astype(float) - background).sum(-1) < 30
        assert sky[:, :12].mean() > sky[:, -12:].mean() + 0.2  # upright: sky at the top, table and floor below
    sheet = np.asarray(__import__("PIL.Image", fromlist=["Image"]).open(report.frames_png))
    assert sheet.shape[1] == 3 * 64
    messages = [(topic, msg) for topic, _, msg in iter_messages(report.mcap) if topic.startswith("/video/")]
    for task in TASKS:
        frames = [m for t, m in messages if t == f"/video/eval/{task}"]
        assert [m["frame_index"] for m in frames] == list(range(8)) and frames[0]["format"] == "png"


def test_video_every_records_every_kth_step_of_the_same_episode(checkpoint: Path, noiseless_video_report,
                                                               tmp_path: Path) -> None:
    def silence(policy) -> None:  # the fixture's noiseless policy: both evaluations see the same episode
        with torch.no_grad():
            policy.head.log_std.fill_(-30.0)

    args = parse_args([f"checkpoint={checkpoint}", "episodes=2", "device=cpu", f"out={tmp_path}", "video=true",
                       "video_frames=4", "video_every=2", "video_size=64x48", "seed=3"])
    report = evaluate(args, policy_hook=silence)
    assert report.info["video"]["every"] == 2 and noiseless_video_report.info["video"]["every"] == 1
    for task, path in report.videos.items():
        strided, full = read_video(path).astype(float), read_video(noiseless_video_report.videos[task]).astype(float)
        assert strided.shape[0] == 4
        # steps 0, 2, 4, 6 (the 2-pixel progress bar along the bottom differs)
        assert np.abs(strided[:, :-2] - full[0:8:2, :-2]).mean() < 2.0
        odd, even = full[1:7:2, :-2], full[2:8:2, :-2]  # steps 1, 3, 5 and 2, 4, 6
        assert np.abs(strided[1:, :-2] - odd).mean() > np.abs(strided[1:, :-2] - even).mean()


@pytest.mark.parametrize("steps, frames, every, expected", [
    (150, None, None, (150, 1)),    # Meta-World: the whole episode, every step
    (2000, None, None, (143, 14)),  # Parkour: the whole episode in at most 150 frames
    (2000, 8, None, (8, 1)),        # frames given: the first 8 steps
    (2000, None, 100, (20, 100)),   # stride given: the whole episode at that stride
    (2000, 30, 10, (30, 10)),
])
def test_video_schedule_known_answers(steps: int, frames: int | None, every: int | None,
                                      expected: tuple[int, int]) -> None:
    assert video_schedule(steps, frames, every) == expected


@pytest.mark.parametrize("frames, every, message", [
    (21, 100, "video_frames=21 is out of range; video_frames must be an integer in [1, 20] (the episode length 2000 / "
              "video_every 100, rounded up)"),
    (None, 2001, "video_every=2001 is out of range; video_every must be an integer in [1, 2000]"),
])
def test_video_schedule_names_the_parameter_and_its_range(frames: int | None, every: int, message: str) -> None:
    with pytest.raises(EvalArgumentError, match=re.escape(message)):
        video_schedule(2000, frames, every)


def test_video_files_keep_every_frame_and_grids_tile_row_major(tmp_path: Path) -> None:
    still = np.full((40, 24, 32, 3), 120, dtype=np.uint8)  # a robot that does not move: identical frames
    path = write_video(tmp_path / "still", still, fps=30)
    frames = read_video(path)
    assert frames.shape == (40, 24, 32, 3)
    assert np.array_equal(frames[:, :-2], still[:, :-2])  # only the 2-pixel progress bar is added
    worlds = torch.arange(4, dtype=torch.uint8).reshape(4, 1, 1, 1).expand(4, 2, 3, 3)  # world i has value i
    grid = tile(worlds, 2)
    assert grid.shape == (4, 6, 3)
    assert grid[0, 0, 0] == 0 and grid[0, 3, 0] == 1 and grid[2, 0, 0] == 2 and grid[3, 5, 0] == 3


def test_contact_sheet_labels_stay_in_their_cells() -> None:
    frames = [np.full((20, 60, 3), 200, dtype=np.uint8)] * 2
    sheet = contact_sheet(frames, ["stepping_stones_randomly_arranged (step 75)", ""])
    assert sheet.shape == (36, 120, 3)  # a 16-pixel label strip above each frame
    first_strip, second_strip = sheet[:16, :60], sheet[:16, 60:]
    assert (first_strip < 128).any()  # the (shortened) label is drawn
    assert (second_strip == 255).all()  # and nothing of it reaches the next cell


def test_run_episodes_counts_full_episodes_per_task() -> None:
    env = SyntheticMTEnv([2, 3, 2], max_episode_steps=5, random_initial_progress=False, seed=0)

    def policy(td, deterministic):
        return torch.zeros(td.batch_size[0], env.action_dim)

    result = run_episodes(env, policy, episodes=5, deterministic=True, seed=0)
    assert result.episodes == [6, 9, 6]  # ceil(5 / 2) = 3 passes of one episode per world
    assert result.lengths == [5.0, 5.0, 5.0]
    assert all(0.0 <= s <= 1.0 for s in result.success) and result.metric == "success"


def test_run_episodes_counts_only_the_first_episode_of_every_world() -> None:
    # every step succeeds and ends the episode (radius 10): a 5-step pass ends 5 episodes per world, of which
    # only the first counts (MTBench's player: the first episode of every env)
    env = SyntheticMTEnv([2, 3, 2], max_episode_steps=5, random_initial_progress=False, seed=0,
                         success_radius=10.0, terminate_on_success=True)

    def policy(td, deterministic):
        return torch.zeros(td.batch_size[0], env.action_dim)

    result = run_episodes(env, policy, episodes=2, deterministic=True, seed=0)
    assert result.episodes == [2, 3, 2]
    assert result.lengths == [1.0, 1.0, 1.0] and result.success == [1.0, 1.0, 1.0]
    # the env counts every episode when nobody excludes any: 5 per world in the same 5 steps
    env.reset()
    env.pop_episode_stats()
    td = env.reset()
    for _ in range(5):
        td.set("action", policy(td, True))
        _, td = env.step_and_maybe_reset(td)
    assert env.pop_episode_stats()["episodes"].tolist() == [10.0, 15.0, 10.0]


def test_on_step_sees_which_worlds_ended_their_first_episode() -> None:
    env = SyntheticMTEnv([2, 3, 2], max_episode_steps=5, random_initial_progress=False, seed=0,
                         success_radius=10.0, terminate_on_success=True)  # every episode ends after one step
    seen = []
    run_episodes(env, lambda td, det: torch.zeros(td.batch_size[0], env.action_dim), episodes=1, deterministic=True,
                 seed=0, on_step=lambda p, t, finished: seen.append((t, finished.clone())))
    assert [t for t, _ in seen] == [0, 1, 2, 3, 4]
    assert not seen[0][1].any() and all(f.all() for _, f in seen[1:])


class _CountingRenderer:  # renders each world's frame as the number of render calls so far
    def __init__(self, world_index: torch.Tensor) -> None:
        self.world_index, self.calls = world_index, 0

    def render(self) -> torch.Tensor:
        self.calls += 1
        return torch.full((*self.world_index.shape, 2, 2, 3), self.calls, dtype=torch.uint8)


def test_video_of_a_world_stops_at_the_end_of_its_first_episode() -> None:
    from mtbench.evaluation.video import VideoRecorder

    recorder = VideoRecorder.__new__(VideoRecorder)  # the recorder's logic with a stand-in renderer
    recorder.frames, recorder.grid, recorder.every, recorder.captured = 4, 1, 2, 0
    recorder.renderer = _CountingRenderer(torch.tensor([[3], [0]]))  # two tasks, rendering worlds 3 and 0
    recorder._buffer = torch.zeros(4, 2, 1, 2, 2, 3, dtype=torch.uint8)
    finished = torch.zeros(5, dtype=torch.bool)
    for t in range(8):
        if t == 3:
            finished[3] = True  # world 3's first episode ended before step 3 (and it was reset)
        recorder.capture(t, finished)
    videos = recorder.videos()  # [tasks, frames, H, W, 3], one render per recorded step 0, 2, 4, 6
    assert videos[1, :, 0, 0, 0].tolist() == [1, 2, 3, 4]  # world 0 plays on
    assert videos[0, :, 0, 0, 0].tolist() == [1, 2, 2, 2]  # world 3 keeps its last frame before the end


def test_run_episodes_resets_a_stateful_policy_after_every_env_reset() -> None:
    env = SyntheticMTEnv([2, 3, 2], max_episode_steps=5, random_initial_progress=False, seed=0)
    calls: list[str] = []

    class Stateful:
        def reset(self) -> None:
            calls.append("reset")

        def __call__(self, td, deterministic):
            calls.append("act")
            return torch.zeros(td.batch_size[0], env.action_dim)

    run_episodes(env, Stateful(), episodes=5, deterministic=True, seed=0)
    assert calls == (["reset"] + ["act"] * 5) * 3  # 3 passes of 5 steps


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        ([], "missing parameter 'checkpoint'"),
        (["checkpoint=/no/such/file.pt"], "checkpoint='/no/such/file.pt': no such file"),
        (["checkpoint={dir}"], "is a directory"),
        (["checkpoint={ckpt}", "episodes=0"], "episodes=0 is out of range; episodes must be an integer >= 1"),
        (["checkpoint={ckpt}", "episodes=-3"], "episodes must be an integer >= 1"),
        (["checkpoint={ckpt}", "episodes=ten"], "episodes='ten' is not an integer"),
        (["checkpoint={ckpt}", "episodes=2.5"], "episodes='2.5' is not an integer"),
        (["checkpoint={ckpt}", "num_envs=0"], "num_envs must be an integer >= 1"),
        (["checkpoint={ckpt}", "epsiodes=3"], "unknown parameter 'epsiodes'; valid keys: checkpoint, episodes"),
        (["checkpoint={ckpt}", "device=tpu"], "device='tpu' is not a valid device; valid choices: auto, cpu, cuda"),
        (["checkpoint={ckpt}", "video=maybe"], "video='maybe' is not a boolean; valid choices: true, false"),
        (["checkpoint={ckpt}", "deterministic=2"], "deterministic='2' is not a boolean"),
        (["checkpoint={ckpt}", "seed=-1"], "seed=-1 is out of range"),
        (["checkpoint={ckpt}", "video_size=10x10"], "each side must be in [16, 4096]"),
        (["checkpoint={ckpt}", "video_size=big"], "video_size='big' is not WIDTHxHEIGHT"),
        (["checkpoint={ckpt}", "video_grid=3"],
         "video_grid=3 is out of range; video_grid must be an integer in [1, 2]"),
        (["checkpoint={ckpt}", "episodes"], "argument 'episodes' is not key=value"),
        (["checkpoint={ckpt}", "episodes=1", "episodes=2"], "parameter 'episodes' is given twice"),
        (["checkpoint={ckpt}", "env.num_envs=8"], "unknown parameter 'env.num_envs'; the env is changed with "
                                                   "env.name=... (tasks or terrains) and env.overrides.<key>=..."),
        (["checkpoint={ckpt}", "env.overrides.seed=1", "env.overrides.seed=2"],
         "parameter 'env.overrides.seed' is given twice"),
        (["checkpoint={ckpt}", "env.name="], "env.name= is empty; give a value"),
    ],
)
def test_bad_arguments_name_the_parameter_and_valid_values(tmp_path: Path, argv: list[str], message: str) -> None:
    ckpt = tmp_path / "final.pt"
    ckpt.write_bytes(b"")
    argv = [a.format(ckpt=ckpt, dir=tmp_path) for a in argv]
    with pytest.raises(EvalArgumentError) as err:
        parse_args(argv)
    assert message in str(err.value)


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the message on a machine without CUDA")
def test_cuda_without_a_gpu_is_refused(tmp_path: Path) -> None:
    (tmp_path / "final.pt").write_bytes(b"")
    with pytest.raises(EvalArgumentError, match=r"device='cuda': CUDA is not available .* valid choices here: auto"):
        parse_args([f"checkpoint={tmp_path / 'final.pt'}", "device=cuda"])


def test_bad_checkpoints_and_sizes_are_refused(checkpoint: Path, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    garbage = tmp_path / "garbage.pt"
    garbage.write_text("not a checkpoint")
    with pytest.raises(EvalArgumentError, match="cannot be read as a checkpoint written by Trainer.save"):
        evaluate(parse_args([f"checkpoint={garbage}"]))
    plain = tmp_path / "plain.pt"  # a torch file, not an mtbench checkpoint
    torch.save({"weights": {}}, plain)
    with pytest.raises(EvalArgumentError, match="not an mtbench checkpoint"):
        evaluate(parse_args([f"checkpoint={plain}"]))
    foreign = tmp_path / "foreign.pt"  # an mtbench checkpoint file without a training run in it
    save_checkpoint(foreign, {"version": CHECKPOINT_VERSION, "weights": {}})
    with pytest.raises(EvalArgumentError, match=r"lacks \['config', 'loss'\]"):
        evaluate(parse_args([f"checkpoint={foreign}"]))
    with pytest.raises(EvalArgumentError, match=r"num_envs=2 is smaller than the number of tasks \(3\)"):
        evaluate(parse_args([f"checkpoint={checkpoint}", "num_envs=2", "device=cpu"]))
    # the same errors through the command line: exit status 2 and the message on stderr
    assert main([f"checkpoint={checkpoint}", "video=true", "device=cpu", f"video_frames={EPISODE_STEPS + 1}",
                 f"out={tmp_path / 'x'}"]) == 2
    expected = (f"video_frames={EPISODE_STEPS + 1} is out of range; "
                f"video_frames must be an integer in [1, {EPISODE_STEPS}]")
    assert expected in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_task_slots_map_the_env_tasks_onto_the_policys_slots() -> None:
    """Known answer: an env of [drawer_close, reach] (its own ids 0, 1 and a 2-wide one-hot) for a policy trained on
    [reach, drawer_close, button_press_topdown] -> slots 1 and 0 of a 3-wide one-hot; the state is untouched."""
    slots = task_slots(["reach", "drawer_close", "button_press_topdown"], ["drawer_close", "reach"])
    assert slots == TaskSlots(("reach", "drawer_close", "button_press_topdown"), (1, 0))
    state = torch.arange(6.0).reshape(3, 2)
    env_task = torch.tensor([0, 1, 0])
    obs = torch.cat([state, torch.nn.functional.one_hot(env_task, 2).float()], -1)
    out, slot = slots.policy_input(obs, env_task)
    assert slot.tolist() == [1, 0, 1]
    assert torch.equal(out, torch.tensor([[0.0, 1, 0, 1, 0], [2, 3, 1, 0, 0], [4, 5, 0, 1, 0]]))
    assert slots.descriptions[2] == task_class("button_press_topdown").description
    # the same tasks in the same order, and Parkour (21 canonical slots for any terrains): nothing to map
    assert task_slots("mt10_rand", "mt10") is None and task_slots("mt50", "mt50_rand") is None
    assert task_slots("parkour_easy", ["flat"]) is None
    assert task_slots("mt10_rand", "pick_place").slots == (5,)  # MT10's task-id order
    with pytest.raises(EvalArgumentError, match=re.escape(
            "env.name=['reach', 'assembly'] has tasks this policy was not trained on: ['assembly']; its task slots "
            "are the 10 tasks of env.name=mt10_rand: valid choices: mt10 or mt10_rand or a list of some of them, in "
            "any order (button_press_topdown, door_open,")):
        task_slots("mt10_rand", ["reach", "assembly"])
    with pytest.raises(EvalArgumentError, match=r"^env.name=\['reach', 'reach'\] names a task twice"):
        task_slots("mt10_rand", ["reach", "reach"])
    with pytest.raises(EvalArgumentError, match=r"^env.name=bogus: unknown Meta-World env name 'bogus'; valid "):
        task_slots("mt10", "bogus")


def test_a_reordered_subset_of_the_run_tasks_acts_as_the_policy_in_its_own_slots(checkpoint: Path,
                                                                                  tmp_path: Path) -> None:
    """The policy evaluated on [button_press_topdown, reach] (env ids 0, 1) gives every world the action that the
    run's policy gives the same state with the task's own slot (2, 0) -- the known answer of the mapping -- and
    ``evaluate`` runs such an env end to end."""
    state = read_checkpoint(checkpoint)
    env = make_eval_env(state["config"]["env"] | {"name": ["button_press_topdown", "reach"]}, 4, torch.device("cpu"),
                        seed=1)
    try:
        slots = task_slots(state["config"]["env"]["name"], ["button_press_topdown", "reach"])
        policy = load_policy(state, env, torch.device("cpu"), task_slots=slots)
        td = env.reset()
        full = load_policy(state, make_eval_env(state["config"]["env"], 3, torch.device("cpu"), seed=1),
                           torch.device("cpu"))
        obs, env_task = td["observation"], td["task_id"]
        slot = torch.tensor([2, 0])[env_task]
        as_trained = TensorDict({"observation": torch.cat([obs[:, :-2], torch.nn.functional.one_hot(slot, 3).float()],
                                                          -1), "task_id": slot}, batch_size=[4])
        assert env_task.tolist() == [0, 0, 1, 1]
        assert torch.equal(policy(td, deterministic=True), full(as_trained, deterministic=True))
    finally:
        env.close()
    report = evaluate(parse_args([f"checkpoint={checkpoint}", "env.name=[button_press_topdown,reach]", "device=cpu",
                                  "episodes=1", "deterministic=true", f"out={tmp_path}"]), logger="none")
    assert report.results[0].task_names == ["button_press_topdown", "reach"] and report.results[0].episodes == [1, 1]


def test_passes_count_only_tasks_with_worlds() -> None:
    """A Parkour flat pre-training checkpoint has worlds for one of its 21 task slots: the passes are counted over
    the tasks that have worlds (a task without worlds needs no episode)."""
    from types import SimpleNamespace

    from mtbench.evaluation.episodes import passes_needed, worlds_per_task

    flat = SimpleNamespace(task_counts=[0] * 20 + [4])
    assert worlds_per_task(flat) == [0] * 20 + [4]
    assert passes_needed(flat, 10) == 3 and passes_needed(flat, 4) == 1
    assert passes_needed(SimpleNamespace(task_counts=[3, 2, 5]), 5) == 3  # the smallest block sets the passes


def test_report_tables_leave_out_task_slots_without_worlds_and_give_end_shares() -> None:
    """Known answers: a task slot with no episode in any evaluation is left out (with a line saying so); the end
    reasons become each task's shares of its counted episodes."""
    from mtbench.evaluation.episodes import EvalResult
    from mtbench.evaluation.report import end_table, markdown_table

    nan = float("nan")
    result = EvalResult("deterministic", "progress", ["a", "b", "c"], [2, 0, 4], [0.5, nan, 0.25], [1.0, nan, 2.0],
                        [10.0, nan, 5.0], {"unhealthy": [0, 0, 0], "end_time": [1, 0, 1], "end_roll": [1, 0, 3]})
    table = markdown_table([result])
    rows = [line.split("|")[1].strip() for line in table.splitlines() if line.startswith("|")]
    assert rows == ["task", "---", "a", "c", "**mean**"]
    assert "**37.5%**" in table and "(1 task slot without worlds in this env not shown)" in table
    shares = result.end_shares()
    assert list(shares) == ["time", "roll"] and shares["roll"][2] == 0.75 and shares["time"][0] == 0.5
    assert math.isnan(shares["time"][1])
    ends = [[c.strip() for c in line.split("|")[1:-1]] for line in end_table([result]).splitlines()]
    assert ends[0] == ["task", "time", "roll"] and ends[2:] == [["a", "50.0%", "50.0%"], ["c", "25.0%", "75.0%"]]
    no_ends = EvalResult("sampled", "success", ["a"], [1], [1.0], [0.0], [1.0])
    assert end_table([no_ends]) == "" and no_ends.end_shares() == {}


def test_eval_env_keeps_the_contacts_a_parkour_run_trained_on() -> None:
    """A Parkour run's config from before ``robot_contact_timeconst`` existed (MuJoCo's soft contacts then) is
    evaluated on soft contacts, not on today's stiffer default; a named value is kept; Meta-World is untouched."""
    old = eval_env_config({"name": "parkour_easy", "num_envs": 4096, "overrides": {"num_rows": 10}}, 42)
    assert old.num_envs == 42 and old.overrides.random_start_progress is False
    assert "robot_contact_timeconst" in old.overrides and old.overrides.robot_contact_timeconst is None
    named = eval_env_config({"name": ["box_jump_even", "flat"], "num_envs": 8,
                             "overrides": {"robot_contact_timeconst": 0.01}}, 2)
    assert named.overrides.robot_contact_timeconst == 0.01
    assert "robot_contact_timeconst" not in eval_env_config({"name": "mt10_rand", "num_envs": 8}, 10).overrides


def test_env_overrides_are_parsed_and_merged_into_the_run_env(tmp_path: Path) -> None:
    from omegaconf import OmegaConf

    from mtbench.evaluation.run import with_env_overrides

    ckpt = tmp_path / "final.pt"
    ckpt.write_bytes(b"")
    args = parse_args([f"checkpoint={ckpt}", "env.name=[box_jump_even,flat]", "+env.overrides.curriculum=true",
                       "env.overrides.max_init_level=0", "episodes=2"])
    assert args.env_overrides == ("env.name=[box_jump_even,flat]", "env.overrides.curriculum=true",
                                  "env.overrides.max_init_level=0") and args.episodes == 2
    run_env = OmegaConf.create({"name": "parkour_hard_cl", "num_envs": 4096,
                                "overrides": {"num_rows": 10, "curriculum": False}})
    env = with_env_overrides(run_env, args.env_overrides)
    assert OmegaConf.to_container(env) == {"name": ["box_jump_even", "flat"], "num_envs": 4096,
                                           "overrides": {"num_rows": 10, "curriculum": True, "max_init_level": 0}}
    assert parse_args([f"checkpoint={ckpt}"]).env_overrides == ()
