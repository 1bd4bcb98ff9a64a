"""MT-GRPO: Monte-Carlo reward-to-go within the window, per-task (group) standardised advantages, loss."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict
from torchrl.modules import ProbabilisticActor

from mtbench.objectives.grpo import MTGRPOLoss, discounted_reward_to_go, grpo_advantages
from mtbench.objectives.per_task_returns import PerTaskMCAdvantage
from mtbench.trainer.actor_critic import make_actor


def test_reward_to_go_with_done_in_the_middle() -> None:
    # r = 1..5, the transition at t=1 ends an episode: G_1 = r_1 only, G_0 = r_0 + g * r_1
    r = torch.tensor([1.0, 2.0, 3.0, 4.0, 5.0])
    done = torch.tensor([False, True, False, False, False])
    g = discounted_reward_to_go(r, done, gamma=0.9, time_dim=0)
    expected = torch.tensor([1 + 0.9 * 2, 2.0, 3 + 0.9 * (4 + 0.9 * 5), 4 + 0.9 * 5, 5.0])
    torch.testing.assert_close(g, expected)
    # no bootstrap at the end of the window: a window ending mid-episode gets the truncated sum
    g2 = discounted_reward_to_go(r[None, :, None], done[None, :, None], gamma=0.9, time_dim=1)
    torch.testing.assert_close(g2[0, :, 0], expected)
    with pytest.raises(ValueError, match="same shape"):
        discounted_reward_to_go(r, done[:3], gamma=0.9, time_dim=0)


def test_grpo_advantages_standardised_per_task_over_the_batch() -> None:
    gen = torch.Generator().manual_seed(0)
    n, t = 6, 7
    reward = torch.randn(n, t, 1, generator=gen) * torch.tensor([1.0, 1.0, 10.0, 10.0, 100.0, 100.0])[:, None, None]
    done = torch.rand(n, t, 1, generator=gen) < 0.2
    task = torch.tensor([0, 0, 1, 1, 2, 2])[:, None].expand(n, t)
    adv, ret = grpo_advantages(reward, done, task, 3, gamma=0.99)
    torch.testing.assert_close(ret, discounted_reward_to_go(reward, done, 0.99, time_dim=1))
    for k in range(3):
        m = task == k
        x = ret[..., 0][m]
        torch.testing.assert_close(adv[..., 0][m], (x - x.mean()) / (x.std() + 1e-8))
        assert adv[..., 0][m].mean().abs() < 1e-5
        assert adv[..., 0][m].std().item() == pytest.approx(1.0, abs=1e-5)


def _rollout_td(actor: ProbabilisticActor, n: int = 4, t: int = 5) -> TensorDict:
    gen = torch.Generator().manual_seed(1)
    td = TensorDict(
        {
            "observation": torch.cat([torch.randn(n, t, 3, generator=gen), torch.eye(2)[torch.tensor([0, 0, 1, 1])][:, None].expand(n, t, 2)], -1),
            "task_id": torch.tensor([0, 0, 1, 1])[:, None].expand(n, t).clone(),
            "next": {
                "reward": torch.randn(n, t, 1, generator=gen),
                "done": torch.zeros(n, t, 1, dtype=torch.bool),
                "terminated": torch.zeros(n, t, 1, dtype=torch.bool),
                "truncated": torch.zeros(n, t, 1, dtype=torch.bool),
            },
        },
        batch_size=[n, t],
    )
    td["next", "done"][:, 2] = True
    with torch.no_grad():
        actor(td)
    return td


def test_grpo_loss_uses_batch_advantages_without_minibatch_renormalisation() -> None:
    actor = make_actor(None, obs_dim=5, action_dim=2, num_tasks=2)
    loss = MTGRPOLoss(actor, num_tasks=2, reduction="none")
    data = _rollout_td(actor)
    assert isinstance(loss.value_estimator, PerTaskMCAdvantage)
    prepared = loss.value_estimator(data.clone(False))
    adv, _ = grpo_advantages(data["next", "reward"], data["next", "done"], data["task_id"], 2)
    torch.testing.assert_close(prepared["advantage"], adv)
    flat = prepared.reshape(-1)
    sub = flat[torch.tensor([0, 1, 2, 12, 17])]  # a minibatch whose per-task advantage mean is not 0
    out = loss(sub)
    # ratio == 1 at the first minibatch: loss_objective = -A exactly (no per-minibatch standardisation)
    torch.testing.assert_close(-out["loss_objective"], sub["advantage"][:, 0])
    assert "loss_critic" not in out.keys()
    assert set(k for k in out.keys() if k.startswith("loss_")) == {"loss_objective", "loss_entropy", "loss_bounds"}
    assert all("critic" not in name for name, _ in loss.named_parameters())


def test_grpo_clipped_surrogate() -> None:
    net_actor = make_actor(None, obs_dim=5, action_dim=2, num_tasks=2)
    loss = MTGRPOLoss(net_actor, num_tasks=2, reduction="none", clip_epsilon=0.2)
    data = _rollout_td(net_actor).reshape(-1)
    data["advantage"] = torch.linspace(-2, 2, data.numel())[:, None]
    shift = torch.linspace(-0.5, 0.5, data.numel())
    data["action_log_prob"] = data["action_log_prob"] - shift  # ratio = exp(shift)
    out = loss(data)
    ratio = shift.exp()
    a = data["advantage"][:, 0]
    expected = -torch.minimum(ratio * a, ratio.clamp(0.8, 1.2) * a)
    torch.testing.assert_close(out["loss_objective"], expected, rtol=1e-5, atol=1e-6)
