"""Faults that must not poison a run: non-finite actions and non-finite physics state in a few worlds, for every env
family (Meta-World MT10 tasks, Meta-World MT50-only tasks, Parkour)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import pytest
import torch
import warp as wp

from mtbench.envs import make_env


@dataclass(frozen=True)
class Family:
    """How to build a 6-world, 2-task env of a family and reach the simulator of a world."""

    make: Callable[[int], object]
    action_dim: int
    # world -> (sim, index of the world in that sim)
    world_sim: Callable[[object, int], tuple[object, int]]
    # a position coordinate of a free body (puck / robot base) to make non-finite
    free_qpos_index: int


def _metaworld_sim(env, world: int):
    for _, state in env.blocks:
        if world < state.n:
            return state.sim, world
        world -= state.n
    raise IndexError(world)


FAMILIES = {
    "metaworld_mt10": Family(
        lambda seed: make_env(["reach", "push"], num_envs=[3, 3], device="cpu", seed=seed,
                              random_start_progress=False),
        4, _metaworld_sim, -7),
    "metaworld_mt50": Family(
        lambda seed: make_env(["hammer", "bin_picking"], num_envs=[3, 3], device="cpu", seed=seed,
                              random_start_progress=False),
        4, _metaworld_sim, -7),
    "parkour": Family(
        lambda seed: make_env(["flat", "balance_beam"], num_envs=6, device="cpu", seed=seed, num_rows=2,
                              random_start_progress=False),
        12, lambda env, world: (env.sim, world), 0),
}


@pytest.fixture(params=sorted(FAMILIES))
def family(request: pytest.FixtureRequest) -> Family:
    return FAMILIES[request.param]


def _all_finite_rows(sim) -> torch.Tensor:
    """Bool ``[nworld]``: every per-world float array of the simulator (state, derived quantities, constraint
    rows) is finite."""
    ok = torch.ones(sim.nworld, dtype=torch.bool)
    for rows in sim._clean_rows:
        ok &= torch.isfinite(wp.to_torch(rows)).all(-1)
    return ok


def _sims(family: Family, env) -> list:
    return list({id(s): s for s in (family.world_sim(env, w)[0] for w in range(6))}.values())


def test_nonfinite_actions_are_replaced_by_zero_and_counted(family: Family) -> None:
    """A NaN/inf action component acts as 0 (exactly: the run equals one given 0 there) and is counted per task."""
    env, ref = family.make(0), family.make(0)
    td, td_ref = env.reset(), ref.reset()
    g = torch.Generator().manual_seed(0)
    for step in range(4):
        action = torch.rand(6, family.action_dim, generator=g) * 2 - 1
        bad = action.clone()
        if step == 1:
            bad[1, 0], bad[4, 3], bad[5] = float("nan"), float("inf"), float("-inf")
            action[1, 0], action[4, 3], action[5] = 0.0, 0.0, 0.0
        td["action"], td_ref["action"] = bad, action
        out, td = env.step_and_maybe_reset(td)
        out_ref, td_ref = ref.step_and_maybe_reset(td_ref)
        assert torch.equal(out["next", "observation"], out_ref["next", "observation"]), step
        assert torch.equal(out["next", "reward"], out_ref["next", "reward"]), step
    stats = env.pop_episode_stats()
    # per task: world 1 (first task) once, worlds 4 and 5 (second task) once each
    expected = torch.bincount(env.task_id[[1, 4, 5]], minlength=env.num_tasks).float()
    assert torch.equal(stats["nonfinite_actions"], expected)
    assert stats["unhealthy"].sum() == 0


def test_a_world_with_nonfinite_state_is_reset_once_and_recovers_the_others_untouched(family: Family) -> None:
    env, ref = family.make(0), family.make(0)
    td, td_ref = env.reset(), ref.reset()
    g = torch.Generator().manual_seed(1)
    unhealthy = 0.0
    for step in range(8):
        if step == 2:  # NaN velocity in world 1, an infinite free-body position in world 5
            sim, i = family.world_sim(env, 1)
            sim.qvel[i, 0] = float("nan")
            sim, i = family.world_sim(env, 5)
            sim.qpos[i, family.free_qpos_index] = float("inf")
        action = torch.rand(6, family.action_dim, generator=g) * 2 - 1
        td["action"], td_ref["action"] = action, action.clone()
        out, td = env.step_and_maybe_reset(td)
        out_ref, td_ref = ref.step_and_maybe_reset(td_ref)
        good = torch.tensor([True, False, True, True, True, False])
        # the other worlds are untouched: bit-identical to a run without the fault
        assert torch.equal(out["next", "observation"][good], out_ref["next", "observation"][good]), step
        # TorchRL's native autoreset NaN-fills ("next", "observation") of done rows; the new episodes' first
        # observations (the root of the returned td) and all rewards are finite
        assert torch.isfinite(td["observation"]).all() and torch.isfinite(out["next", "reward"]).all()
        if step == 2:
            assert out["next", "done"].squeeze(-1).tolist() == [False, True, False, False, False, True]
            assert out["next", "reward"][~good].eq(0).all()  # no reward from a blown-up state
        unhealthy += float(env.pop_episode_stats()["unhealthy"].sum())
        ref.pop_episode_stats()
    # reset once, then healthy again: every derived physics quantity of the reset worlds is finite
    assert unhealthy == 2.0
    assert all(_all_finite_rows(sim).all() for sim in _sims(family, env))


def test_a_full_reset_restores_a_world_whose_derived_quantities_went_nonfinite(family: Family) -> None:
    """MuJoCo Warp's reset restores the state but not e.g. the constraint rows its solver reads: without the
    clean-up the world turned NaN again at every step after the reset."""
    env = family.make(0)
    td = env.reset()
    sim, i = family.world_sim(env, 0)
    sim.qvel[i, 2] = float("nan")
    td["action"] = torch.zeros(6, family.action_dim)
    env.step_and_maybe_reset(td)  # the NaN spreads through the step before the world is reset
    env.pop_episode_stats()
    td = env.reset()
    for _ in range(5):
        td["action"] = torch.zeros(6, family.action_dim)
        _, td = env.step_and_maybe_reset(td)
    assert env.pop_episode_stats()["unhealthy"].sum() == 0
    assert all(_all_finite_rows(s).all() for s in _sims(family, env))
