"""mtbench's losses, estimators and wrappers are TorchRL-native: equivalence with stock TorchRL, every key
settable with ``set_keys``, one task-id key, and stock TorchRL losses train through mtbench's trainer."""

from __future__ import annotations

import copy
import math

import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import InteractionType, TensorDictModule
from torchrl.envs import TransformedEnv
from torchrl.modules import IndependentNormal, ProbabilisticActor
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE

from envs_for_tests import SyntheticMTEnv
from mtbench.objectives import MTGRPOLoss, MTPPOLoss, PCGrad, PerTaskGAE, PerTaskMCAdvantage, compute_gradients
from mtbench.trainer import NonFiniteGuard, Rollout, Trainer, make_actor, make_critic
from mtbench.trainer.actor_critic import GaussianPolicyHead
from mtbench.transforms import PerTaskObservationNorm

K, STATE, ACT = 3, 5, 2
OBS = STATE + K


def _nets(seed: int = 0, *, keys: dict[str, str] | None = None) -> tuple[ProbabilisticActor, TensorDictModule]:
    """Gaussian actor and critic (MLP [16, 16]); ``keys`` renames their task-id / loc / scale / action /
    log-prob / value entries."""
    k = {"task_id": "task_id", "loc": "loc", "scale": "scale", "action": "action", "lp": "action_log_prob",
         "value": "state_value", **(keys or {})}
    torch.manual_seed(seed)
    arch = {"name": "mlp", "kwargs": {"hidden": [16, 16]}}
    base_actor = make_actor(arch, obs_dim=OBS, action_dim=ACT, num_tasks=K)
    head = next(m for m in base_actor.modules() if isinstance(m, GaussianPolicyHead))
    actor = ProbabilisticActor(
        TensorDictModule(head, in_keys=["observation", k["task_id"]], out_keys=[k["loc"], k["scale"]]),
        in_keys={"loc": k["loc"], "scale": k["scale"]},
        out_keys=[k["action"]],
        distribution_class=IndependentNormal,
        return_log_prob=True,
        log_prob_key=k["lp"],
        default_interaction_type=InteractionType.RANDOM,
    )
    net = make_critic(arch, obs_dim=OBS, num_tasks=K).module
    critic = TensorDictModule(net, in_keys=["observation", k["task_id"]], out_keys=[k["value"]])
    return actor, critic


def _rollout(actor: ProbabilisticActor, n: int = 6, t: int = 7, seed: int = 1) -> TensorDict:
    """A ``[n, t]`` native-autoreset rollout: ``("next", observation)[t] = observation[t + 1]`` except on done
    (truncated) steps, whose next observation is NaN."""
    g = torch.Generator().manual_seed(seed)
    task = torch.tensor([0, 0, 1, 1, 2, 2])[:n]
    onehot = torch.eye(K)[task][:, None].expand(n, t + 1, K)
    seq = torch.cat([torch.randn(n, t + 1, STATE, generator=g), onehot], -1)
    obs, nxt = seq[:, :-1], seq[:, 1:].clone()  # after a done step, obs[t + 1] starts the next episode
    truncated = torch.rand(n, t, 1, generator=g) < 0.2
    truncated[:, -1] = torch.tensor([True, False, False, True, False, False])[:n, None]
    nxt[truncated.squeeze(-1)] = float("nan")
    td = TensorDict(
        {
            "observation": obs,
            "task_id": task[:, None].expand(n, t).clone(),
            "next": {
                "observation": nxt,
                "task_id": task[:, None].expand(n, t).clone(),
                "reward": torch.randn(n, t, 1, generator=g) * torch.tensor([1.0, 1, 10, 10, 100, 100])[:n, None, None],
                "done": truncated.clone(),
                "terminated": torch.zeros_like(truncated),
                "truncated": truncated,
            },
        },
        batch_size=[n, t],
    )
    with torch.no_grad():
        actor(td)
    return td


def _rename(td: TensorDict, names: dict[str, str]) -> TensorDict:
    out = td.clone()
    for old, new in names.items():
        for prefix in ((), ("next",)):
            if prefix + (old,) in out.keys(include_nested=True):
                out.rename_key_(prefix + (old,), prefix + (new,))
    return out


def test_mt_ppo_with_the_multitask_features_off_equals_clip_ppo_loss() -> None:
    actor, critic = _nets()
    mt = MTPPOLoss(actor, critic, num_tasks=K, normalize_value=False, per_task_advantage_norm=False,
                   bounds_coeff=0.0, critic_coef=4.0, clip_value=0.2, entropy_coeff=0.005)
    actor2, critic2 = copy.deepcopy(actor), copy.deepcopy(critic)
    stock = ClipPPOLoss(actor2, critic2, clip_epsilon=0.2, entropy_coeff=0.005, critic_coeff=2.0,
                        loss_critic_type="l2", clip_value=0.2, normalize_advantage=False)
    stock.make_value_estimator(GAE(gamma=0.99, lmbda=0.95, value_network=critic2, auto_reset_env=True))
    data = _rollout(actor)
    assert isinstance(mt.value_estimator, PerTaskGAE) and mt.value_estimator.value_norm is None
    with torch.no_grad():
        ours = mt.value_estimator(data.clone(False))
        theirs = stock.value_estimator(data.clone(False))
    # PerTaskGAE without value normalisation is GAE(auto_reset_env=True) on a native-autoreset rollout
    for key in ("advantage", "value_target"):
        torch.testing.assert_close(ours[key], theirs[key], rtol=1e-5, atol=1e-5)
    batch = ours.exclude("next").reshape(-1)  # with the old values (state_value) for value clipping
    with torch.no_grad():  # a policy that moved: ratios != 1 and clipped values
        for p in actor.parameters():
            p.add_(0.05 * torch.randn_like(p))
        for p in critic.parameters():
            p.add_(0.05 * torch.randn_like(p))
        for a, b in zip(actor.parameters(), actor2.parameters()):
            b.copy_(a)
        for a, b in zip(critic.parameters(), critic2.parameters()):
            b.copy_(a)
    out_mt, out_stock = mt(batch), stock(batch)
    assert 0 < float(out_mt["clip_fraction"]) < 1 and 0 < float(out_mt["value_clip_fraction"]) < 1
    for key in ("loss_objective", "loss_critic", "loss_entropy"):
        torch.testing.assert_close(out_mt[key], out_stock[key], rtol=1e-5, atol=1e-7)
    assert float(out_mt["loss_bounds"].detach()) == 0.0
    torch.testing.assert_close(out_mt["clip_fraction"], out_stock["clip_fraction"])
    compute_gradients(mt, batch)
    compute_gradients(stock, batch)
    for (name, p), q in zip(mt.named_parameters(), stock.parameters()):
        assert p.grad is not None and p.grad.abs().sum() > 0, name
        torch.testing.assert_close(p.grad, q.grad, rtol=1e-5, atol=1e-7), name


RENAMES = {"task_id": "tid", "truncated": "trunc", "reward": "rew", "done": "dn", "terminated": "term",
           "loc": "mu", "scale": "sigma", "action": "act", "action_log_prob": "lp", "state_value": "sv"}


def test_every_key_of_the_losses_and_estimators_is_settable() -> None:
    keys = {"task_id": "tid", "loc": "mu", "scale": "sigma", "action": "act", "lp": "lp", "value": "sv"}
    actor, critic = _nets(keys=keys)
    ref_actor, ref_critic = _nets()
    renamed = MTPPOLoss(actor, critic, num_tasks=K)
    renamed.set_keys(task_id="tid", truncated="trunc", reward="rew", done="dn", terminated="term", loc="mu",
                     scale="sigma", action="act", sample_log_prob="lp", value="sv", advantage="adv",
                     value_target="vt", returns="ret")
    est = renamed.value_estimator
    assert (est.tensor_keys.task_id, est.tensor_keys.truncated, est.tensor_keys.returns) == ("tid", "trunc", "ret")
    assert (est.tensor_keys.reward, est.tensor_keys.done, est.tensor_keys.advantage) == ("rew", "dn", "adv")
    assert {"tid", "mu", "sigma", "act", "lp", "adv", "vt", "sv"} <= set(renamed.in_keys)
    ref = MTPPOLoss(ref_actor, ref_critic, num_tasks=K)
    data = _rollout(ref_actor)
    data_renamed = _rename(data, RENAMES)
    with torch.no_grad():
        a = ref.value_estimator(data.clone(False))
        b = renamed.value_estimator(data_renamed.clone(False))
    torch.testing.assert_close(a["advantage"], b["adv"])
    torch.testing.assert_close(a["value_target"], b["vt"])
    torch.testing.assert_close(a["returns"], b["ret"])
    assert "advantage" not in b.keys() and "returns" not in b.keys()
    out_a, out_b = ref(a.exclude("next").reshape(-1)), renamed(b.exclude("next").reshape(-1))
    for key in ("loss_objective", "loss_critic", "loss_entropy", "loss_bounds", "kl"):
        torch.testing.assert_close(out_a[key], out_b[key])

    grpo_ref, grpo = MTGRPOLoss(ref_actor, num_tasks=K), MTGRPOLoss(actor, num_tasks=K)
    grpo.set_keys(task_id="tid", reward="rew", done="dn", loc="mu", scale="sigma", action="act",
                  sample_log_prob="lp", advantage="adv", returns="ret")
    assert isinstance(grpo.value_estimator, PerTaskMCAdvantage) and grpo.value_estimator.tensor_keys.task_id == "tid"
    a, b = grpo_ref.value_estimator(data.clone(False)), grpo.value_estimator(data_renamed.clone(False))
    torch.testing.assert_close(a["advantage"], b["adv"])
    torch.testing.assert_close(grpo_ref(a.exclude("next").reshape(-1))["loss_objective"],
                               grpo(b.exclude("next").reshape(-1))["loss_objective"])
    with pytest.raises(KeyError, match="value_estimator"):
        ref(data.exclude("next").reshape(-1))  # no advantage yet: the error says what to run


def test_gradient_wrappers_read_the_loss_task_id_key() -> None:
    actor, critic = _nets(keys={"task_id": "tid"})
    loss = MTPPOLoss(actor, critic, num_tasks=K)
    wrapper = PCGrad(loss, K)
    wrapper.set_keys(task_id="tid")  # one call renames it for the wrapper and the loss
    assert loss.tensor_keys.task_id == "tid" and wrapper.task_id_key == "tid"
    assert loss.value_estimator.tensor_keys.task_id == "tid" and "tid" in wrapper.in_keys
    loss.set_keys(task_id="task")  # the wrapper follows the loss's declared key
    assert wrapper.task_id_key == "task"
    loss.set_keys(task_id="tid")
    data = _rename(_rollout(_nets()[0]), {"task_id": "tid"})
    with torch.no_grad():
        batch = loss.value_estimator(data.clone(False)).exclude("next").reshape(-1)
    metrics = wrapper.backward(batch)
    assert torch.equal(metrics["task_count"], torch.full((K,), 14.0))
    stock = ClipPPOLoss(*_nets())  # declares no task id: the wrapper's own key
    stock_wrapper = PCGrad(stock, K)
    stock_wrapper.set_keys(task_id="group")
    assert stock_wrapper.task_id_key == "group" and not hasattr(stock.tensor_keys, "task_id")


def _synthetic_run(loss_factory, iterations: int = 12) -> list[dict[str, float]]:
    env = TransformedEnv(SyntheticMTEnv([8, 8, 8], max_episode_steps=8, seed=0), PerTaskObservationNorm(K))
    torch.manual_seed(0)
    actor = make_actor({"name": "mlp", "kwargs": {"hidden": [32, 32]}}, obs_dim=2 * ACT + 1 + K, action_dim=ACT,
                       num_tasks=K)
    critic = make_critic({"name": "mlp", "kwargs": {"hidden": [32, 32]}}, obs_dim=2 * ACT + 1 + K, num_tasks=K)
    loss = loss_factory(actor, critic)
    optimizer = torch.optim.Adam(loss.parameters(), lr=3e-3, fused=True)
    trainer = Trainer(env, actor, loss, optimizer, horizon=16, epochs=4, minibatch_size=96,
                      total_iterations=iterations, max_grad_norm=1.0, hooks=[NonFiniteGuard()])
    return trainer.train()


def test_stock_clip_ppo_loss_with_stock_gae_trains_through_the_trainer() -> None:
    def stock(actor, critic):
        loss = ClipPPOLoss(actor, critic, entropy_coeff=0.0, critic_coeff=1.0, loss_critic_type="l2")
        loss.make_value_estimator(GAE(gamma=0.9, lmbda=0.95, value_network=critic, auto_reset_env=True))
        return loss

    history = _synthetic_run(stock)
    assert all(h["train/skipped_updates"] == 0 and math.isfinite(h["loss/objective"]) for h in history)
    assert {"loss/critic", "train/ESS", "train/grad_norm", "success/task0"} <= set(history[-1])
    first, last = history[1]["return/mean"], history[-1]["return/mean"]
    assert last > first + 5.0, (first, last)  # it learns: mean episode return rises


def test_rollout_matches_torchrl_collector() -> None:
    """The explicit rollout collects exactly what TorchRL's Collector collects (same keys, same values)."""
    from torchrl.collectors import Collector

    def run(use_collector: bool) -> TensorDict:
        env = TransformedEnv(SyntheticMTEnv([2, 2, 2], max_episode_steps=5, seed=0), PerTaskObservationNorm(K))
        env.__dict__["_torchrl_native_autoreset"] = True
        env.base_env.__dict__["_torchrl_native_autoreset"] = True
        torch.manual_seed(0)
        actor = make_actor(None, obs_dim=2 * ACT + 1 + K, action_dim=ACT, num_tasks=K)
        if use_collector:
            collector = Collector(env, actor, frames_per_batch=6 * 7, total_frames=-1, trust_policy=True,
                                  track_traj_ids=False, auto_register_policy_transforms=False)
            it = iter(collector)
            torch.manual_seed(1)  # the Collector's construction draws from the policy
            return torch.cat([next(it).clone() for _ in range(2)], 1)
        rollout = Rollout(env, actor, 7)
        torch.manual_seed(1)
        return torch.cat([rollout.collect().clone() for _ in range(2)], 1)

    a, b = run(True), run(False)
    assert set(a.keys(True, True)) == set(b.keys(True, True))
    for key in a.keys(True, True):
        assert torch.equal(a[key].nan_to_num(7.0), b[key].nan_to_num(7.0)), key
