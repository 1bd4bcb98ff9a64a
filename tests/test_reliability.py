"""Faults that must not poison a run: non-finite actions and non-finite physics state in a few worlds."""

from __future__ import annotations

import torch
import warp as wp

from mtbench.envs import make_env


def _env(seed: int = 0):
    return make_env(["reach", "push"], num_envs=[3, 3], device="cpu", seed=seed, random_start_progress=False)


def _all_finite_rows(sim) -> torch.Tensor:
    """Bool ``[nworld]``: every per-world float array of the simulator (state, derived quantities, constraint
    rows) is finite."""
    ok = torch.ones(sim.nworld, dtype=torch.bool)
    for rows in sim._clean_rows:
        ok &= torch.isfinite(wp.to_torch(rows)).all(-1)
    return ok


def test_nonfinite_actions_are_replaced_by_zero_and_counted() -> None:
    """A NaN/inf action component acts as 0 (exactly: the run equals one given 0 there) and is counted per task."""
    env, ref = _env(), _env()
    td, td_ref = env.reset(), ref.reset()
    g = torch.Generator().manual_seed(0)
    for step in range(4):
        action = torch.rand(6, 4, generator=g) * 2 - 1
        bad = action.clone()
        if step == 1:
            bad[1, 0], bad[4, 3], bad[5] = float("nan"), float("inf"), float("-inf")
            action[1, 0], action[4, 3], action[5] = 0.0, 0.0, 0.0
        td["action"], td_ref["action"] = bad, action
        out, td = env.step_and_maybe_reset(td)
        out_ref, td_ref = ref.step_and_maybe_reset(td_ref)
        assert torch.equal(out["next", "observation"], out_ref["next", "observation"])
        assert torch.equal(out["next", "reward"], out_ref["next", "reward"])
    stats = env.pop_episode_stats()
    assert stats["nonfinite_actions"].tolist() == [1.0, 2.0]  # one reach world, two push worlds (one step)
    assert stats["unhealthy"].tolist() == [0.0, 0.0]


def test_a_world_with_nonfinite_state_is_reset_once_and_recovers_the_others_untouched() -> None:
    env, ref = _env(), _env()
    td, td_ref = env.reset(), ref.reset()
    reach_sim = env.blocks[0][1].sim
    push_sim = env.blocks[1][1].sim
    g = torch.Generator().manual_seed(1)
    unhealthy = torch.zeros(2)
    for step in range(8):
        if step == 2:  # NaN velocity in reach world 1, inf position of the puck in push world 2 (world 5)
            reach_sim.qvel[1, 0] = float("nan")
            push_sim.qpos[2, -7] = float("inf")
        action = torch.rand(6, 4, generator=g) * 2 - 1
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
        unhealthy += env.pop_episode_stats()["unhealthy"]
        ref.pop_episode_stats()
    # reset once, then healthy again: every derived physics quantity of the reset worlds is finite
    assert unhealthy.tolist() == [1.0, 1.0]
    assert _all_finite_rows(reach_sim).all() and _all_finite_rows(push_sim).all()


def test_a_full_reset_restores_a_world_whose_derived_quantities_went_nonfinite() -> None:
    """MuJoCo Warp's reset restores the state but not e.g. the constraint rows its solver reads: without the
    clean-up the world turned NaN again at every step after the reset."""
    env = _env()
    td = env.reset()
    sim = env.blocks[0][1].sim
    sim.qvel[0, 2] = float("nan")
    td["action"] = torch.zeros(6, 4)
    env.step_and_maybe_reset(td)  # the NaN spreads through the step before the world is reset
    env.pop_episode_stats()
    td = env.reset()
    for _ in range(5):
        td["action"] = torch.zeros(6, 4)
        _, td = env.step_and_maybe_reset(td)
    assert env.pop_episode_stats()["unhealthy"].sum() == 0
    assert _all_finite_rows(sim).all()
