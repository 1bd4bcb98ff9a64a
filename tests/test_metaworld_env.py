"""The Meta-World env contract: TorchRL specs, native autoreset, seeding, reward/observation layout, errors."""

from __future__ import annotations

import pytest
import torch
from torchrl.collectors import Collector
from torchrl.envs.utils import check_env_specs

from mtbench.envs import make_env, split_envs
from mtbench.envs.metaworld import TASKS
from mtbench.envs.metaworld.env import STATE_DIM
from metaworld_rollout import random_actions, rollout


def _run(env, actions: torch.Tensor):
    return rollout(env, actions)[1:4]  # observations, rewards, dones


def test_check_env_specs_two_tasks() -> None:
    env = make_env(["reach", "reach"][:1] + [t for t in ("push", "drawer_close") if t in TASKS][:1],
                   num_envs=4, device="cpu", seed=0)
    check_env_specs(env)
    assert env.observation_spec["observation"].shape[-1] == STATE_DIM + env.num_tasks


def test_observation_layout_and_task_ids() -> None:
    env = make_env("reach", num_envs=3, device="cpu", seed=0)
    td = env.reset()
    obs = td["observation"]
    assert obs.shape == (3, STATE_DIM + 1) and torch.all(obs[:, -1] == 1)
    assert torch.equal(td["task_id"], torch.zeros(3, dtype=torch.long))
    # first observation of an episode: the previous frame equals the current frame (Meta-World)
    assert torch.equal(obs[:, 0:18], obs[:, 18:36])
    # the goal (last 3 state dims) lies in the task's reset range
    low, high = torch.tensor(TASKS["reach"].reset_low[3:]), torch.tensor(TASKS["reach"].reset_high[3:])
    assert torch.all(obs[:, 36:39] >= low - 1e-6) and torch.all(obs[:, 36:39] <= high + 1e-6)
    # gripper starts open and the TCP starts at the task's initial hand position
    assert torch.all(obs[:, 3] > 0.8)
    assert torch.allclose(obs[:, 0:3], torch.tensor(TASKS["reach"].scene.hand_init_pos).expand(3, 3), atol=3e-3)


def test_autoreset_episode_length_and_statistics() -> None:
    env = make_env("reach", num_envs=4, device="cpu", seed=0, episode_length=10, random_start_progress=False)
    obs, rewards, dones = _run(env, random_actions(env, 25, 0))
    done_steps = dones[:, :, 0].all(dim=1).nonzero().flatten().tolist()
    assert done_steps == [9, 19]
    assert int(dones.sum()) == 8  # only at the truncation steps
    # the observation returned with done=True is the first of the next episode (prev frame == frame)
    assert torch.equal(obs[10][:, 0:18], obs[10][:, 18:36])
    assert not torch.equal(obs[9][:, 0:18], obs[9][:, 18:36])
    stats = env.pop_episode_stats()
    assert stats["episodes"].tolist() == [8.0]
    assert stats["length"].tolist() == [80.0]
    assert torch.allclose(stats["return"], rewards[:20].sum(), rtol=1e-5)
    assert env.pop_episode_stats()["episodes"].tolist() == [0.0]  # popped


def test_torchrl_native_autoreset_path_is_used() -> None:
    """TorchRL takes the native path (terminal next-obs NaN-filled, no second reset of finished worlds)."""
    env = make_env("reach", num_envs=2, device="cpu", seed=0, episode_length=3, random_start_progress=False)
    td = env.reset()
    for t in range(3):
        td["action"] = torch.zeros(2, 4)
        out, td = env.step_and_maybe_reset(td)
    assert out["next", "done"].all()
    assert torch.isnan(out["next", "observation"]).all()  # native path marks the terminal obs invalid
    assert torch.isfinite(td["observation"]).all() and not td["done"].any()
    assert torch.equal(env._step_count, torch.zeros(2, dtype=torch.long))  # reset exactly once


def test_random_start_progress_skips_partial_first_episodes() -> None:
    env = make_env("reach", num_envs=16, device="cpu", seed=3, episode_length=20)
    _, _, dones = _run(env, random_actions(env, 30, 1))
    stats = env.pop_episode_stats()
    # every world finished its (shortened) first episode; the ones that started at step 0 finished a full one
    assert int(dones.sum()) >= 16
    assert float(stats["length"]) == pytest.approx(20.0 * float(stats["episodes"]))


def test_seeded_runs_are_reproducible() -> None:
    a = make_env("reach", num_envs=3, device="cpu", seed=7, episode_length=15)
    b = make_env("reach", num_envs=3, device="cpu", seed=7, episode_length=15)
    c = make_env("reach", num_envs=3, device="cpu", seed=8, episode_length=15)
    actions = random_actions(a, 40, 2)
    oa, ra, _ = _run(a, actions)
    ob, rb, _ = _run(b, actions)
    oc, _, _ = _run(c, actions)
    assert torch.equal(oa, ob) and torch.equal(ra, rb)
    assert not torch.equal(oa[:, :, 36:39], oc[:, :, 36:39])


def test_fixed_goals_persist_and_rand_goals_change() -> None:
    fixed = make_env("reach", num_envs=4, device="cpu", seed=1, rand=False, episode_length=5,
                     random_start_progress=False)
    rand = make_env("reach", num_envs=4, device="cpu", seed=1, rand=True, episode_length=5,
                    random_start_progress=False)
    of, _, _ = _run(fixed, random_actions(fixed, 12, 0))
    orr, _, _ = _run(rand, random_actions(rand, 12, 0))
    goals_f, goals_r = of[:, :, 36:39], orr[:, :, 36:39]
    assert torch.equal(goals_f[0], goals_f[5]) and torch.equal(goals_f[0], goals_f[10])
    assert len({tuple(g.tolist()) for g in goals_f[0]}) == 4  # each world has its own goal
    assert not torch.equal(goals_r[0], goals_r[5])


def test_reward_scale_applies_to_dense_steps_only() -> None:
    kw = dict(num_envs=4, device="cpu", seed=5, random_start_progress=False)
    env100, env50 = make_env("reach", reward_scale=100.0, **kw), make_env("reach", reward_scale=50.0, **kw)
    actions = random_actions(env100, 8, 3) * 0.2
    _, r100, _ = _run(env100, actions)
    _, r50, _ = _run(env50, actions)
    dense = r100 < 10.0
    assert dense.any()
    assert torch.allclose(r100[dense], 2 * r50[dense], rtol=1e-5)


def test_success_gives_the_constant_bonus() -> None:
    from mtbench.envs.metaworld.policies import scripted_policy

    env = make_env("reach", num_envs=2, device="cpu", seed=0, random_start_progress=False)
    td, policy, rewards = env.reset(), scripted_policy("reach"), []
    for _ in range(60):
        td["action"] = policy(td["observation"][:, :STATE_DIM])
        out, td = env.step_and_maybe_reset(td)
        rewards.append(out["next", "reward"])
    rewards = torch.cat(rewards, dim=1)
    assert torch.all(rewards[:, -1] == 10.0)  # solved and held: bonus every step, not accumulated
    assert torch.all(rewards[:, 0] < 10.0)


def test_collector_with_native_autoreset() -> None:
    env = make_env("reach", num_envs=4, device="cpu", seed=0, episode_length=6)
    collector = Collector(env, policy=None, frames_per_batch=4 * 8, total_frames=4 * 16, trust_policy=True)
    batches = list(collector)
    collector.shutdown()
    assert len(batches) == 2 and batches[0].shape == (4, 8)
    assert torch.isfinite(batches[1]["next", "reward"]).all()
    assert batches[0]["next", "done"].any()


def test_bad_inputs_give_clear_errors() -> None:
    with pytest.raises(ValueError, match="valid choices"):
        make_env("mt11")
    with pytest.raises(ValueError, match="unknown task names"):
        make_env(["reach", "not_a_task"])
    with pytest.raises(ValueError, match="one per task"):
        make_env(["reach"], num_envs=[2, 2])
    with pytest.raises(ValueError, match="positive"):
        make_env(["reach"], num_envs=[0])
    with pytest.raises(ValueError, match="smaller than the number of tasks"):
        make_env("mt10", num_envs=5)
    if not torch.cuda.is_available():
        with pytest.raises(RuntimeError, match="CUDA is not available"):
            make_env("reach", num_envs=1, device="cuda")


def test_split_envs_matches_mtbench() -> None:
    assert split_envs(24576, 10) == [2458] * 6 + [2457] * 4
    assert split_envs(24576, 50) == [492] * 26 + [491] * 24
    assert split_envs(4096, 10) == [410] * 6 + [409] * 4


def test_state_dict_round_trip_continues_the_same_trajectories() -> None:
    kw = dict(num_envs=3, device="cpu", episode_length=12)
    a = make_env("reach", seed=4, **kw)
    actions = random_actions(a, 30, 9)
    td = a.reset()
    for act in actions[:17]:
        td["action"] = act
        _, td = a.step_and_maybe_reset(td)
    state = a.state_dict()
    b = make_env("reach", seed=123, **kw)  # different seed: everything must come from the state
    b.load_state_dict(state)
    td_b = td.clone()
    for act in actions[17:]:
        td["action"], td_b["action"] = act, act
        out_a, td = a.step_and_maybe_reset(td)
        out_b, td_b = b.step_and_maybe_reset(td_b)
        # same state, same inputs: the same trajectory up to the Newton solver's tolerance (derived solver
        # buffers are recomputed, not stored); goals, episode clocks and RNG draws are identical
        assert torch.allclose(td["observation"], td_b["observation"], atol=1e-3)
        assert torch.equal(td["observation"][:, 36:], td_b["observation"][:, 36:])
        assert torch.allclose(out_a["next", "reward"], out_b["next", "reward"], atol=1e-2)
        assert torch.equal(out_a["next", "done"], out_b["next", "done"])
    assert torch.equal(a._step_count, b._step_count)
    assert torch.equal(a.pop_episode_stats()["episodes"], b.pop_episode_stats()["episodes"])
    other = make_env(["reach"], num_envs=[2], device="cpu")
    with pytest.raises(RuntimeError, match="env state is for tasks"):
        other.load_state_dict(state)


def test_reward_version_is_validated_and_recorded_with_the_state() -> None:
    with pytest.raises(ValueError, match="reward_version.*valid choices.*paper.*v2"):
        make_env("reach", num_envs=1, device="cpu", reward_version="v3")
    paper = make_env("reach", num_envs=2, device="cpu", seed=0)
    assert paper.reward_version == "paper"
    paper.reset()
    state = paper.state_dict()
    v2 = make_env("reach", num_envs=2, device="cpu", seed=0, reward_version="v2")
    with pytest.raises(RuntimeError, match="reward_version='paper'.*across reward versions"):
        v2.load_state_dict(state)


def test_observation_layout_matches_the_named_state() -> None:
    """The env's observation, parsed with the one layout module, equals the named task state it encodes."""
    from mtbench.envs.metaworld import observation as layout

    env = make_env(["push", "drawer_close"], num_envs=[2, 2], device="cpu", seed=3, random_start_progress=False)
    td = env.reset()
    td["action"] = torch.rand(4, 4) * 2 - 1
    prev = layout.parse(td["observation"])
    _, td = env.step_and_maybe_reset(td)
    obs = layout.parse(td["observation"])
    for (task, s), sl in zip(env.blocks, env.slices):
        torch.testing.assert_close(obs["tcp"][sl], s.tcp)
        torch.testing.assert_close(obs["gripper_open"][sl], s.gripper_open)
        torch.testing.assert_close(obs["obj_pos"][sl], s.obj_pos)
        torch.testing.assert_close(obs["obj_quat"][sl], s.obj_quat)
        torch.testing.assert_close(obs["obj2_pos"][sl], s.obj2_pos)
        torch.testing.assert_close(obs["goal"][sl], s.goal)
        # the previous frame is the previous observation's current frame
        torch.testing.assert_close(obs["prev_tcp"][sl], prev["tcp"][sl])
        torch.testing.assert_close(obs["prev_obj_pos"][sl], prev["obj_pos"][sl])
    # push's puck is a free body: its observed pose is the body pose; drawer_close reports no orientation
    push, s = env.blocks[0]
    torch.testing.assert_close(s.obj_pos, s.sim.xpos[:, push.obj_body])
    assert torch.equal(env.blocks[1][1].obj_quat, torch.zeros(2, 4))
    assert td["observation"].shape == (4, layout.STATE_DIM + 2)
    with pytest.raises(ValueError, match="at least 39"):
        layout.parse(torch.zeros(3, 20))


def test_docs_show_the_observation_layout() -> None:
    from pathlib import Path

    from mtbench.envs.metaworld.observation import markdown_table

    docs = (Path(__file__).resolve().parents[1] / "docs" / "metaworld.md").read_text()
    assert markdown_table() in docs


def test_task_registry_is_derived_from_the_task_files() -> None:
    """One task class per public module of tasks/, named after its file, ordered by MTBench task id, each with a
    unique id and description; MT10 is in MTBench's id order."""
    import pkgutil

    from mtbench.envs.metaworld import ALL_TASK_NAMES, MT10, benchmark_tasks, tasks

    files = sorted(m.name for m in pkgutil.iter_modules(tasks.__path__) if not m.name.startswith("_"))
    assert sorted(TASKS) == files
    ids = [TASKS[n].mtbench_id for n in ALL_TASK_NAMES]
    assert ids == sorted(ids) and len(set(ids)) == len(ids)
    descriptions = [TASKS[n].description for n in ALL_TASK_NAMES]
    assert len(set(descriptions)) == len(descriptions) and all(d.endswith(".") for d in descriptions)
    assert [TASKS[n].mtbench_id for n in benchmark_tasks("mt10")] == [4, 16, 17, 18, 28, 31, 38, 40, 48, 49]
    assert set(benchmark_tasks("mt10")) == set(MT10)
    env = make_env(["reach", "push"], num_envs=[1, 1], device="cpu")
    assert env.task_descriptions == [TASKS["reach"].description, TASKS["push"].description]


def test_paper_rewards_use_the_original_tolerance_and_v2_the_correct_one() -> None:
    """Same physics in both reward versions; the paper version's dense rewards are the task's formula evaluated with
    the original MTBench ``tolerance`` (0 inside its bounds), so they differ once the puck is caged."""
    from mtbench.envs.metaworld.policies import scripted_policy
    from mtbench.envs.metaworld.reward_utils import mtbench_tolerance

    envs = {v: make_env("push", num_envs=4, device="cpu", seed=5, random_start_progress=False, reward_version=v)
            for v in ("paper", "v2")}
    tds = {v: e.reset() for v, e in envs.items()}
    policy = scripted_policy("push")
    differ = 0
    for _ in range(60):
        action = policy(tds["paper"]["observation"])
        outs = {}
        for v, e in envs.items():
            tds[v]["action"] = action
            outs[v], tds[v] = e.step_and_maybe_reset(tds[v])
        assert torch.equal(outs["paper"]["next", "observation"], outs["v2"]["next", "observation"])
        task, s = envs["paper"].blocks[0]
        with mtbench_tolerance():
            expected = task.reward(s, action) * task.dense_scale * 100.0
        success = task.success(s, action)
        expected = torch.where(success, torch.full_like(expected, 10.0), expected)
        torch.testing.assert_close(outs["paper"]["next", "reward"].squeeze(-1), expected)
        differ += int((outs["paper"]["next", "reward"] != outs["v2"]["next", "reward"]).sum())
    assert differ > 0


def test_excluded_episodes_are_left_out_of_the_statistics() -> None:
    env = make_env(["reach", "push"], num_envs=[2, 2], device="cpu", seed=0, episode_length=3,
                   random_start_progress=False)
    still = torch.zeros(3, 4, 4)  # one 3-step episode of every world
    td = rollout(env, still)[0]
    assert env.pop_episode_stats()["episodes"].tolist() == [2.0, 2.0]
    env.exclude_episodes(torch.tensor([True, False, True, True]))
    rollout(env, still, td)
    assert env.pop_episode_stats()["episodes"].tolist() == [1.0, 0.0]


def test_mt50_settings_pass_torchrl_spec_checks() -> None:
    env = make_env("mt50_rand", num_envs=50, device="cpu", seed=0)
    assert env.num_tasks == 50 and env.rand and env.task_counts == [1] * 50
    assert env.observation_spec["observation"].shape == (50, 39 + 50)
    check_env_specs(env)
    fixed = make_env("mt50", num_envs=100, device="cpu", seed=0)
    assert not fixed.rand and fixed.task_counts == [2] * 50
    # the layout conf/env/mt50*.yaml select: 30 shared physics models
    grouped = make_env("mt50_rand", num_envs=50, device="cpu", seed=0, group_models=True)
    assert len(grouped.sims) == 30
    check_env_specs(grouped)
    # the paper's split of 24,576 worlds over MT50
    assert split_envs(24576, 50) == [492] * 26 + [491] * 24


def test_compiled_stages_give_the_eager_steps() -> None:
    """``compile_stages=True`` (Inductor on the CPU here) runs the same step: observations, rewards (the paper-era
    ``tolerance`` flag is honoured inside the compiled code) and dones of 30 random steps with resets, against the
    uncompiled env from the same seed; the reset draws stay eager (same generator stream)."""
    kwargs = dict(num_envs=8, device="cpu", seed=4, episode_length=12, reward_version="paper")
    plain = make_env(["push", "pick_place_wall"], **kwargs)
    compiled = make_env(["push", "pick_place_wall"], compile_stages=True, **kwargs)
    assert all(hasattr(stage.fn, "_torchdynamo_orig_callable") for stage in compiled._stages if stage.name != "place_objects")
    actions = random_actions(plain, 30, seed=2)
    (obs_a, rew_a, done_a), (obs_b, rew_b, done_b) = _run(plain, actions), _run(compiled, actions)
    assert torch.equal(done_a, done_b) and bool(done_a.any())
    torch.testing.assert_close(obs_b, obs_a, atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(rew_b, rew_a, atol=1e-4, rtol=1e-5)
    with pytest.raises(ValueError, match="compile_stages must be True, False or 'auto'; got 'yes'"):
        make_env("push", num_envs=2, device="cpu", compile_stages="yes")
    assert make_env("push", num_envs=2, device="cpu", compile_stages="auto").compile_stages is False  # CPU: off
