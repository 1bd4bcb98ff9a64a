"""MT-PPO loss: per-task value normalisation, GAE with truncation bootstrap, per-task minibatch advantage
normalisation, clipped value loss, bounds and entropy terms, reduction="none"."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import InteractionType, TensorDictModule
from torch import nn
from torchrl.modules import IndependentNormal, ProbabilisticActor

from mtbench.objectives.mt_utils import per_task_standardize
from mtbench.objectives.per_task_gae import PerTaskGAE
from mtbench.objectives.ppo import MTPPOLoss
from mtbench.trainer.actor_critic import GaussianPolicyHead

GAMMA, LMBDA = 0.99, 0.95


class _Lin(nn.Module):
    """``(observation, task_id) -> Linear(observation)`` with settable weights."""

    def __init__(self, obs_dim: int, out_dim: int) -> None:
        super().__init__()
        self.lin = nn.Linear(obs_dim, out_dim)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        return self.lin(observation)


def _actor(obs_dim: int, action_dim: int, bias: list[float] | None = None) -> ProbabilisticActor:
    net = _Lin(obs_dim, action_dim)
    if bias is not None:
        with torch.no_grad():
            net.lin.weight.zero_()
            net.lin.bias.copy_(torch.tensor(bias))
    head = TensorDictModule(GaussianPolicyHead(net, action_dim), in_keys=["observation", "task_id"], out_keys=["loc", "scale"])
    return ProbabilisticActor(
        head, in_keys=["loc", "scale"], distribution_class=IndependentNormal, return_log_prob=True,
        default_interaction_type=InteractionType.RANDOM,
    )


def _feature0_critic(obs_dim: int) -> TensorDictModule:
    """Critic whose (normalised) output is observation[..., 0]."""
    net = _Lin(obs_dim, 1)
    with torch.no_grad():
        net.lin.weight.zero_()
        net.lin.weight[0, 0] = 1.0
        net.lin.bias.zero_()
    return TensorDictModule(net, in_keys=["observation", "task_id"], out_keys=["state_value"])


def _reference_gae(r, v, v_next, done, trunc):
    """Plain-python GAE with the truncation bootstrap of GAE(auto_reset_env=True)."""
    n, t_len = r.shape
    adv = np.zeros_like(r)
    for i in range(n):
        last = 0.0
        for t in reversed(range(t_len)):
            rew = r[i, t] + GAMMA * v[i, t] * trunc[i, t]
            nd = 1.0 - done[i, t]
            delta = rew + GAMMA * nd * v_next[i, t] - v[i, t]
            last = delta + GAMMA * LMBDA * nd * last
            adv[i, t] = last
    return adv


def test_per_task_gae_value_normalisation_against_hand_computation() -> None:
    # 2 envs (task 0, task 1), 3 steps; obs = [v_norm, 0, one-hot(2)]; the critic reads obs[..., 0]
    v_norm = np.array([[0.5, -1.0, 7.0], [2.0, 0.0, -0.5]])  # 7.0 exercises the +-5 clamp of rl_games
    v_last = np.array([1.5, 3.0])
    r = np.array([[1.0, 2.0, 3.0], [0.5, -1.0, 2.0]])
    trunc = np.array([[0, 1, 0], [0, 0, 0]], dtype=np.float64)
    term = np.array([[0, 0, 0], [1, 0, 0]], dtype=np.float64)
    done = np.maximum(trunc, term)
    task = np.array([0, 1])
    onehot = np.eye(2)[task]

    def obs(v):
        return torch.tensor(np.concatenate([v[..., None], np.zeros_like(v)[..., None], np.broadcast_to(onehot[:, None] if v.ndim == 2 else onehot, v.shape + (2,))], -1), dtype=torch.float32)

    data = TensorDict(
        {
            "observation": obs(v_norm),
            "task_id": torch.tensor(task)[:, None].expand(2, 3).clone(),
            "next": {
                "observation": obs(np.concatenate([v_norm[:, 1:], v_last[:, None]], 1)),
                "reward": torch.tensor(r, dtype=torch.float32)[..., None],
                "done": torch.tensor(done, dtype=torch.bool)[..., None],
                "terminated": torch.tensor(term, dtype=torch.bool)[..., None],
                "truncated": torch.tensor(trunc, dtype=torch.bool)[..., None],
            },
        },
        batch_size=[2, 3],
    )
    loss = MTPPOLoss(_actor(4, 2), _feature0_critic(4), num_tasks=2, gamma=GAMMA, lmbda=LMBDA)
    prior_count, prior_mean, prior_var = np.array([4.0, 9.0]), np.array([1.0, -2.0]), np.array([4.0, 0.25])
    value_norm = loss.value_estimator.value_norm  # the statistics live with the estimator (loss state_dict)
    assert isinstance(loss.value_estimator, PerTaskGAE)
    value_norm.count.copy_(torch.tensor(prior_count))
    value_norm.mean.copy_(torch.tensor(prior_mean)[:, None])
    value_norm.var.copy_(torch.tensor(prior_var)[:, None])
    assert torch.equal(loss.state_dict()["_value_estimator.value_norm.count"], torch.tensor(prior_count))

    with torch.no_grad():
        out = loss.value_estimator(data)

    eps = 1e-5
    std = np.sqrt(prior_var + eps)[task][:, None]
    v_dn = np.clip(v_norm, -5, 5) * std + prior_mean[task][:, None]
    v_next_dn = np.clip(np.concatenate([v_norm[:, 1:], v_last[:, None]], 1), -5, 5) * std + prior_mean[task][:, None]
    adv = _reference_gae(r, v_dn, v_next_dn, done, trunc)
    ret = adv + v_dn
    # truncation bootstrap: the truncated step's return is r + gamma * V(s_t); a terminated step's is r
    assert ret[0, 1] == pytest.approx(r[0, 1] + GAMMA * v_dn[0, 1])
    assert ret[1, 0] == pytest.approx(r[1, 0])
    np.testing.assert_allclose(out["advantage"][..., 0].numpy(), adv, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out["returns"][..., 0].numpy(), ret, rtol=1e-5, atol=1e-5)

    # per-task statistics updated with the returns (parallel formula, independent implementation)
    new_mean, new_var = np.zeros(2), np.zeros(2)
    for k in range(2):
        xb = ret[task == k].ravel()
        na, nb = prior_count[k], xb.size
        n = na + nb
        delta = xb.mean() - prior_mean[k]
        new_mean[k] = prior_mean[k] + delta * nb / n
        new_var[k] = (prior_var[k] * na + xb.var() * nb + delta**2 * na * nb / n) / n
    np.testing.assert_allclose(value_norm.mean[:, 0].numpy(), new_mean, rtol=1e-6)
    np.testing.assert_allclose(value_norm.var[:, 0].numpy(), new_var, rtol=1e-6)
    assert value_norm.count.tolist() == [7.0, 12.0]
    new_std = np.sqrt(new_var + eps)[task][:, None]
    exp_value = np.clip((v_dn - new_mean[task][:, None]) / new_std, -5, 5)
    exp_target = np.clip((ret - new_mean[task][:, None]) / new_std, -5, 5)
    np.testing.assert_allclose(out["state_value"][..., 0].numpy(), exp_value, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out["value_target"][..., 0].numpy(), exp_target, rtol=1e-5, atol=1e-5)
    assert out is data  # TorchRL estimators write into the rollout they get


def test_truncated_last_step_uses_current_value_and_ignores_nan_next_obs() -> None:
    # native autoreset: ("next", "observation") of a done row is NaN-filled by TorchRL
    obs = torch.tensor([[[2.0, 0.0, 1.0], [3.0, 0.0, 1.0]]])  # [N=1, T=2, S=2 + K=1]
    nxt = torch.tensor([[[3.0, 0.0, 1.0], [float("nan"), float("nan"), float("nan")]]])
    data = TensorDict(
        {
            "observation": obs,
            "task_id": torch.zeros(1, 2, dtype=torch.long),
            "next": {
                "observation": nxt,
                "reward": torch.tensor([[[1.0], [2.0]]]),
                "done": torch.tensor([[[False], [True]]]),
                "terminated": torch.zeros(1, 2, 1, dtype=torch.bool),
                "truncated": torch.tensor([[[False], [True]]]),
            },
        },
        batch_size=[1, 2],
    )
    loss = MTPPOLoss(_actor(3, 1), _feature0_critic(3), num_tasks=1, normalize_value=False, gamma=GAMMA, lmbda=LMBDA)
    out = loss.value_estimator(data)
    a1 = 2.0 + GAMMA * 3.0 - 3.0
    a0 = 1.0 + GAMMA * 3.0 - 2.0 + GAMMA * LMBDA * a1
    torch.testing.assert_close(out["advantage"].flatten(), torch.tensor([a0, a1]))
    assert torch.isfinite(out["value_target"]).all()


def _flat_batch(loss: MTPPOLoss, task_id: torch.Tensor, obs_dim: int, seed: int = 0) -> TensorDict:
    gen = torch.Generator().manual_seed(seed)
    b = task_id.numel()
    td = TensorDict({"observation": torch.randn(b, obs_dim, generator=gen), "task_id": task_id}, [b])
    with torch.no_grad():
        loss.actor_network(td)
    td["advantage"] = torch.randn(b, 1, generator=gen) * 3 + 1
    td["value_target"] = torch.randn(b, 1, generator=gen)
    td["state_value"] = torch.randn(b, 1, generator=gen)
    return td


def test_per_task_minibatch_advantage_normalisation() -> None:
    task_id = torch.tensor([0, 0, 0, 0, 0, 2, 2, 2, 2, 2, 2, 1])  # task 1 has a single sample
    loss = MTPPOLoss(_actor(5, 2), _feature0_critic(5), num_tasks=3, reduction="none")
    td = _flat_batch(loss, task_id, 5)
    out = loss(td)
    # first minibatch of an epoch: ratio == 1, so the clipped surrogate is exactly -A_normalised
    adv = td["advantage"][:, 0]
    expected = torch.zeros_like(adv)
    for k in (0, 2):
        m = task_id == k
        expected[m] = (adv[m] - adv[m].mean()) / (adv[m].std() + 1e-8)
    torch.testing.assert_close(-out["loss_objective"], expected, rtol=1e-5, atol=1e-6)
    for k in (0, 2):
        m = task_id == k
        assert (-out["loss_objective"][m]).mean().abs() < 1e-6
        assert (-out["loss_objective"][m]).std().item() == pytest.approx(1.0, abs=1e-5)
    assert out["loss_objective"][11] == 0.0
    torch.testing.assert_close(per_task_standardize(adv, task_id, 3), expected, rtol=1e-5, atol=1e-6)


def test_clipped_value_loss_entropy_bounds_and_reductions() -> None:
    actor = _actor(4, 2, bias=[1.5, -2.0])  # action mean (1.5, -2.0) everywhere
    critic = _feature0_critic(4)
    loss_none = MTPPOLoss(actor, critic, num_tasks=2, reduction="none")
    b = 6
    obs = torch.zeros(b, 4)
    obs[:, 0] = torch.tensor([0.0, 0.5, 1.0, -1.0, 2.0, 0.3])  # critic output V
    td = TensorDict({"observation": obs, "task_id": torch.tensor([0, 0, 0, 1, 1, 1])}, [b])
    with torch.no_grad():
        actor(td)
    td["advantage"] = torch.randn(b, 1)
    td["state_value"] = (obs[:, :1] + torch.tensor([[0.1], [-0.15], [0.5], [-0.6], [0.0], [0.2]]))  # V_old
    td["value_target"] = torch.tensor([[1.0], [0.0], [1.0], [-1.0], [2.5], [0.0]])  # clipping binds on 2, 3
    out = loss_none(td)
    v, v_old, ret = obs[:, 0], td["state_value"][:, 0], td["value_target"][:, 0]
    unclipped = (v - ret) ** 2
    clipped = (v_old + (v - v_old).clamp(-0.2, 0.2) - ret) ** 2
    expected = 0.5 * 4.0 * torch.maximum(unclipped, clipped)
    torch.testing.assert_close(out["loss_critic"], expected)
    small = (v - v_old).abs() <= 0.2
    torch.testing.assert_close(out["loss_critic"][small], 2.0 * unclipped[small])
    assert not torch.allclose(out["loss_critic"][~small], 2.0 * unclipped[~small])
    assert out["value_clip_fraction"].item() == pytest.approx((~small).float().mean().item())

    # bounds loss on the action mean, soft bound 1.1: (1.5 - 1.1)^2 + (-2.0 + 1.1)^2
    torch.testing.assert_close(out["loss_bounds"], torch.full((b,), 1e-4 * (0.4**2 + 0.9**2)))
    # entropy bonus of N(mu, 1) in 2 dims
    torch.testing.assert_close(out["loss_entropy"], torch.full((b,), -0.005 * 2 * 0.5 * math.log(2 * math.pi * math.e)))

    loss_mean = MTPPOLoss(actor, critic, num_tasks=2)
    mean_out = loss_mean(td)
    for key in ("loss_objective", "loss_critic", "loss_entropy", "loss_bounds"):
        assert out[key].shape == (b,)
        torch.testing.assert_close(mean_out[key], out[key].mean())

    total = sum(mean_out[k] for k in mean_out.keys() if k.startswith("loss_"))
    total.backward()
    assert critic.module.lin.weight.grad is not None and critic.module.lin.weight.grad.abs().sum() > 0
    head = actor.module[0].module
    assert head.net.lin.bias.grad.abs().sum() > 0 and head.log_std.grad.abs().sum() > 0


def test_invalid_reduction_names_choices() -> None:
    with pytest.raises(ValueError, match="valid choices"):
        MTPPOLoss(_actor(4, 2), _feature0_critic(4), num_tasks=2, reduction="avg")


def test_kl_metric_is_the_analytic_kl_to_the_behaviour_policy() -> None:
    actor = _actor(4, 2, bias=[1.5, -2.0])
    loss = MTPPOLoss(actor, _feature0_critic(4), num_tasks=2)
    td = _flat_batch(loss, torch.tensor([0, 1, 0, 1]), 4)
    assert loss(td)["kl"].item() == pytest.approx(0.0, abs=1e-4)
    head = actor.module[0].module
    with torch.no_grad():
        head.net.lin.bias += torch.tensor([0.3, 0.0])
        head.log_std.fill_(math.log(1.2))
    # KL(new || old) per dim: log(s_old / s_new) + (s_new^2 + (mu_new - mu_old)^2) / (2 s_old^2) - 1/2
    expected = 2 * math.log(1 / 1.2) + (1.44 + 0.09) / 2 - 0.5 + 1.44 / 2 - 0.5
    assert loss(td)["kl"].item() == pytest.approx(expected, abs=1e-4)
