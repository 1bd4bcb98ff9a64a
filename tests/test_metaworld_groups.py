"""MetaWorldEnv(group_models=True): tasks whose compiled models differ only in per-world batchable fields share one
MuJoCo Warp model and give the same trajectories as one model per task."""

from __future__ import annotations

import pytest
import torch

from mtbench.envs import make_env
from mtbench.envs.metaworld.env import MetaWorldEnv
from mtbench.envs.metaworld.models import compiled_task, physics_groups
from mtbench.sim import UngroupableModels, WarpSim, WarpSimSlice, groupable
from metaworld_rollout import random_actions, rollout

# a strict group of 3 (site_pos differs), one of 2 with identical models, one of 2 whose bodies differ, one of 2
# whose bodies and keyframes (the arm's home pose and the mocap target) differ, and a task alone
TASKS = ["pick_place", "push", "reach", "drawer_open", "drawer_close", "handle_press", "handle_pull", "door_open",
         "door_close", "door_lock"]
GROUPS = [[0, 1, 2], [3, 4], [5, 6], [7, 8], [9]]


def _env(group_models: bool, seed: int = 3, tasks=TASKS) -> MetaWorldEnv:
    return make_env(tasks, num_envs=[2] * len(tasks), device="cpu", seed=seed, rand=True, episode_length=25,
                    group_models=group_models)


def _assert_same(a, b):
    # exact on the CPU: every world's physics does the same operations in one shared model as in its own
    for name, x, y in zip(("observation", "reward", "done", "success"), a, b):
        assert torch.equal(x, y), (name, (x.float() - y.float()).abs().max().item())


def test_grouped_models_give_the_same_trajectories() -> None:
    plain, grouped = _env(False), _env(True)
    assert plain.model_groups == [[i] for i in range(len(TASKS))] and len(plain.sims) == len(TASKS)
    assert grouped.model_groups == GROUPS and len(grouped.sims) == len(GROUPS) < len(TASKS)
    assert [s.nworld for s in grouped.sims] == [6, 4, 4, 4, 2]
    assert isinstance(grouped.blocks[0][1].sim, WarpSimSlice) and isinstance(grouped.blocks[9][1].sim, WarpSim)
    actions = random_actions(plain, 60, 11)  # episode_length 25: past two resets of every world
    a, b = rollout(plain, actions)[1:], rollout(grouped, actions)[1:]
    _assert_same(a, b)
    assert a[2].any()  # resets happened
    sa, sb = plain.pop_episode_stats(), grouped.pop_episode_stats()
    for key in sa.keys():
        assert torch.allclose(sa[key], sb[key], atol=1e-4), key


def test_grouped_state_dict_round_trip() -> None:
    a = _env(True)
    actions = random_actions(a, 50, 5)
    td, *_ = rollout(a, actions[:20])
    state = a.state_dict()
    assert "sims" in state["_extra_state"] and len(state["_extra_state"]["sims"]) == len(GROUPS)
    b = _env(True, seed=99)  # different seed: everything must come from the state
    b.load_state_dict(state)
    out_a = rollout(a, actions[20:], td.clone())[1:]
    out_b = rollout(b, actions[20:], td.clone())[1:]
    # same tolerance as the ungrouped round trip (derived solver buffers are recomputed, not stored)
    for name, x, y in zip(("observation", "reward", "done", "success"), out_a, out_b):
        if x.dtype == torch.bool:
            assert torch.equal(x, y), name
        else:
            assert torch.allclose(x, y, atol=1e-2), (name, (x - y).abs().max().item())
    assert torch.equal(a._step_count, b._step_count)
    with pytest.raises(RuntimeError, match=r"physics blocks.*env.overrides.group_models=true"):
        _env(False).load_state_dict(state)


def test_a_slice_reads_and_clears_only_its_worlds_overflow_bits() -> None:
    env = _env(True, tasks=["pick_place", "push"])
    sim, push = env.sims[0], env.blocks[1][1].sim  # push: worlds 2-3 of the shared sim
    bits = 4  # one mjw.OverflowType bit, set in every world
    sim._overflow.fill_(bits)
    assert push.overflowed(bits, clear=True).tolist() == [True, True]
    assert sim.overflowed(bits).tolist() == [True, True, False, False]
    assert not push.overflowed(bits).any()


def test_models_differing_in_shared_fields_are_not_grouped() -> None:
    env = _env(True, tasks=["reach", "drawer_open", "drawer_close"])
    assert env.model_groups == [[0], [1, 2]] and len(env.sims) == 2
    # one strict signature, but reach_wall's dof_length and bvh_aabb (shared across worlds in MuJoCo Warp) differ
    walls = [compiled_task(t)[1] for t in ("pick_place_wall", "push_wall", "reach_wall")]
    assert groupable(walls[:2]) and not groupable(walls[1:])
    assert physics_groups(walls) == [[0, 1], [2]]
    with pytest.raises(UngroupableModels, match="dof_length"):
        WarpSim(walls[1], 2, "cpu", world_models=[(walls[1], 1), (walls[2], 1)], use_graph=False)
    with pytest.raises(ValueError, match="group_models must be True or False; got 'yes'"):
        make_env("reach", num_envs=2, device="cpu", group_models="yes")
    # different strict groups are never merged
    models = [compiled_task(t)[1] for t in ("reach", "drawer_open")]
    assert physics_groups(models) == [[0], [1]]


def test_tasks_of_one_group_need_not_be_adjacent() -> None:
    """A group's worlds are gathered from non-adjacent task ranges of the env (its sim keeps them contiguous)."""
    tasks = ["pick_place", "drawer_open", "push", "drawer_close", "reach", "door_lock"]
    plain, grouped = _env(False, tasks=tasks), _env(True, tasks=tasks)
    assert grouped.model_groups == [[0, 2, 4], [1, 3], [5]]
    assert all(isinstance(w, torch.Tensor) for w in grouped._sim_worlds[:2])  # gathered from non-adjacent ranges
    actions = random_actions(plain, 60, 4)
    a, b = rollout(plain, actions)[1:], rollout(grouped, actions)[1:]
    _assert_same(a, b)
    assert a[2].any()


def test_grouped_env_renders_as_one_model_per_task() -> None:
    """Each task's frames come from its worlds of the shared sim, as from its own model (same poses: same image)."""
    from mtbench.evaluation.render import EnvRenderer

    tasks = ["drawer_open", "reach", "drawer_close"]
    plain, grouped = _env(False, tasks=tasks), _env(True, tasks=tasks)
    assert grouped.model_groups == [[0, 2], [1]]
    actions = random_actions(plain, 5, 2)
    rollout(plain, actions), rollout(grouped, actions)
    a = EnvRenderer(plain, 32, 24, worlds_per_task=2).render()
    b = EnvRenderer(grouped, 32, 24, worlds_per_task=2).render()
    assert a.shape == b.shape == (3, 2, 24, 32, 3)
    assert (a.int() - b.int()).abs().max() <= 1
    assert not torch.equal(b[0], b[2])  # drawer_open's and drawer_close's own worlds, not the same ones twice


def test_mt_configs_group_where_it_was_measured_faster() -> None:
    """conf/env: MT50 groups its 50 tasks into the 30 blocks measured faster on the GPU; MT10 keeps 10 blocks
    (grouped, 6, was slower there; docs/benchmarks.md §6)."""
    from pathlib import Path

    from omegaconf import OmegaConf

    from mtbench.envs.metaworld.registry import MT10, MT50

    conf = Path(__file__).resolve().parents[1] / "conf" / "env"
    setting = {name: OmegaConf.load(conf / f"{name}.yaml").overrides.group_models
               for name in ("mt10", "mt10_rand", "mt50", "mt50_rand")}
    assert setting == {"mt10": False, "mt10_rand": False, "mt50": True, "mt50_rand": True}
    blocks = physics_groups([compiled_task(t)[1] for t in MT50])
    assert len(blocks) == 30 and sorted(i for b in blocks for i in b) == list(range(50))
    assert len(physics_groups([compiled_task(t)[1] for t in MT10])) == 6
