"""PCGrad, CAGrad and FAMO around any TorchRL loss: stock ClipPPOLoss, stock SACLoss (reduction="none"), mtbench's
MTSACLoss and a minimal DQN-style loss with a single ``loss`` term. The manipulated terms are found from the
parameter groups (which terms reach the critic / actor parameters); the projected gradients are checked against the
known-answer maths already tested for PPO (tests/test_grad_manipulation.py) and, for two conflicting task
gradients, against the reference values of /work/shared/reference/mtrl-algorithms.md section 3."""

from __future__ import annotations

from typing import Callable

import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator
from torchrl.objectives import ClipPPOLoss, LossModule, SACLoss
from torchrl.objectives.utils import ValueEstimators

from cpu_runs import one_torch_thread
from mtbench.objectives import (
    CAGrad,
    FAMO,
    MTSACLoss,
    PCGrad,
    cagrad,
    compute_gradients,
    pcgrad,
    resolve_param_group,
)
from mtbench.objectives.famo import famo_loss_coefficients
from mtbench.objectives.pcgrad import random_task_orders
from mtbench.objectives.task_gradients import flatten
from mtbench.trainer import make_qvalue, make_sac_actor

K, OBS, ACT, N = 3, 6, 2, 36


@pytest.fixture(autouse=True)
def _one_thread():
    with one_torch_thread():
        yield


# ---------------------------------------------------------------------------------------------- losses and batches
def _ids() -> torch.Tensor:
    ids = torch.arange(K).repeat_interleave(N // K)
    return ids[torch.randperm(N, generator=torch.Generator().manual_seed(3))]


def _sign(ids: torch.Tensor) -> torch.Tensor:
    return (1.0 - 2.0 * (ids % 2)).float()[:, None] * (1.0 + ids[:, None])  # odd tasks: opposite targets


def clip_ppo() -> tuple[LossModule, TensorDict]:
    torch.manual_seed(0)
    net = nn.Sequential(nn.Linear(OBS, 16), nn.Tanh(), nn.Linear(16, 2 * ACT), NormalParamExtractor())
    actor = ProbabilisticActor(TensorDictModule(net, ["observation"], ["loc", "scale"]), in_keys=["loc", "scale"],
                               distribution_class=TanhNormal, return_log_prob=True)
    critic = ValueOperator(nn.Sequential(nn.Linear(OBS, 16), nn.Tanh(), nn.Linear(16, 1)), in_keys=["observation"])
    loss = ClipPPOLoss(actor, critic, loss_critic_type="l2")
    ids = _ids()
    g = torch.Generator().manual_seed(1)
    td = TensorDict({"observation": torch.randn(N, OBS, generator=g), "task_id": ids}, [N])
    with torch.no_grad():
        actor(td)
    td["advantage"] = torch.randn(N, 1, generator=g) + _sign(ids)
    td["value_target"] = torch.randn(N, 1, generator=g) + 3.0 * _sign(ids)
    return loss, td


class _QNet(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.net = nn.Sequential(nn.Linear(OBS + ACT, 16), nn.Tanh(), nn.Linear(16, 1))

    def forward(self, observation: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([observation, action], -1))


def _sac_batch(obs_dim: int) -> TensorDict:
    ids = _ids()
    g = torch.Generator().manual_seed(2)
    one_hot = torch.nn.functional.one_hot(ids, K).float()
    obs = torch.cat([torch.randn(N, obs_dim - K, generator=g), one_hot], -1)
    nxt = torch.cat([torch.randn(N, obs_dim - K, generator=g), one_hot], -1)
    no = torch.zeros(N, 1, dtype=torch.bool)
    return TensorDict({"observation": obs, "action": torch.rand(N, ACT, generator=g) * 2 - 1, "task_id": ids,
                       "next": {"observation": nxt, "task_id": ids, "reward": 5.0 * _sign(ids), "done": no,
                                "terminated": no.clone()}}, [N])


def stock_sac() -> tuple[LossModule, TensorDict]:
    torch.manual_seed(0)
    net = nn.Sequential(nn.Linear(OBS, 16), nn.Tanh(), nn.Linear(16, 2 * ACT), NormalParamExtractor())
    actor = ProbabilisticActor(TensorDictModule(net, ["observation"], ["loc", "scale"]), in_keys=["loc", "scale"],
                               distribution_class=TanhNormal)
    q = ValueOperator(_QNet(), in_keys=["observation", "action"], out_keys=["state_action_value"])
    loss = SACLoss(actor, q, loss_function="l2", target_entropy=-float(ACT), reduction="none",
                   scalar_output_mode="exclude")
    loss.make_value_estimator(ValueEstimators.TD0, gamma=0.9)
    return loss, _sac_batch(OBS)


def mt_sac() -> tuple[LossModule, TensorDict]:
    torch.manual_seed(0)
    arch = {"name": "mlp", "kwargs": {"hidden": [16], "activation": "tanh"}}
    actor = make_sac_actor(arch, obs_dim=OBS + K, action_dim=ACT, num_tasks=K)
    qvalues = [make_qvalue(arch, obs_dim=OBS + K, action_dim=ACT, num_tasks=K) for _ in range(2)]
    return MTSACLoss(actor, qvalues, num_tasks=K, gamma=0.9), _sac_batch(OBS + K)


class DQNStyleLoss(LossModule):
    """A minimal DQN-style loss: one network (``value_network``), one term named ``loss`` (TorchRL's ``DQNLoss``
    output convention): ``(Q(s)[a] - y)^2`` per sample."""

    def __init__(self, value_network: nn.Module) -> None:
        super().__init__()
        self.value_network = value_network
        self.reduction = "mean"

    def forward(self, td: TensorDict) -> TensorDict:
        q = self.value_network(td["observation"]).gather(-1, td["action"]).squeeze(-1)
        loss = (q - td["target"]) ** 2
        return TensorDict({"loss": loss if self.reduction == "none" else loss.mean()}, [])


def dqn() -> tuple[LossModule, TensorDict]:
    torch.manual_seed(0)
    loss = DQNStyleLoss(nn.Sequential(nn.Linear(OBS, 16), nn.Tanh(), nn.Linear(16, 3)))
    ids = _ids()
    g = torch.Generator().manual_seed(4)
    td = TensorDict({"observation": torch.randn(N, OBS, generator=g), "task_id": ids,
                     "action": torch.randint(0, 3, (N, 1), generator=g),
                     "target": 3.0 * _sign(ids).squeeze(-1)}, [N])
    return loss, td


LOSSES: dict[str, tuple[Callable[[], tuple[LossModule, TensorDict]], list[str], list[str]]] = {
    # name: (factory, critic terms, actor terms)
    "ClipPPOLoss": (clip_ppo, ["loss_critic"], ["loss_objective", "loss_entropy"]),
    "SACLoss": (stock_sac, ["loss_qvalue"], ["loss_actor"]),
    "MTSACLoss": (mt_sac, ["loss_qvalue"], ["loss_actor"]),
    "DQN-style": (dqn, ["loss"], []),
}


# ---------------------------------------------------------------------------------------------- references
def grads_of(params) -> torch.Tensor:
    return flatten([p.grad if p.grad is not None else torch.zeros_like(p) for p in params])


def reference_task_grads(loss, td, terms, params, seed) -> torch.Tensor:
    """Per-task gradients of the masked-mean ``terms``: one fresh forward and backward pass per task."""
    rows = []
    for k in range(K):
        torch.manual_seed(seed)
        out = loss(td.clone())
        per_sample = sum(out[t].reshape(N, -1).mean(-1) for t in terms)
        task_loss = per_sample[td["task_id"] == k].mean()
        grads = torch.autograd.grad(task_loss, params, allow_unused=True)
        rows.append(flatten([torch.zeros_like(p) if g is None else g for p, g in zip(params, grads)]))
    return torch.stack(rows)


def plain_grads(loss, td, params, seed) -> torch.Tensor:
    """Gradient of the summed batch means of every loss term (what an unwrapped loss would write)."""
    torch.manual_seed(seed)
    out = loss(td.clone())
    total = sum(v.mean() for k, v in out.items() if k == "loss" or k.startswith("loss_"))
    grads = torch.autograd.grad(total, params, allow_unused=True)
    return flatten([torch.zeros_like(p) if g is None else g for p, g in zip(params, grads)])


# ---------------------------------------------------------------------------------------------- tests
@pytest.mark.parametrize("name", sorted(LOSSES))
def test_critic_and_actor_terms_are_found_from_the_parameter_groups(name):
    factory, critic_terms, actor_terms = LOSSES[name]
    loss, td = factory()
    wrapper = PCGrad(loss, K)
    losses = wrapper._task_losses(td.clone())
    assert wrapper._group_term_names("critic", losses) == critic_terms
    assert wrapper._group_term_names("actor", losses) == actor_terms
    assert wrapper.task_id_key == "task_id" and "task_id" in wrapper.in_keys


@pytest.mark.parametrize("method", ["pcgrad", "cagrad", "famo"])
@pytest.mark.parametrize("name", sorted(LOSSES))
def test_methods_around_any_loss_match_the_known_maths(name, method):
    factory, critic_terms, _ = LOSSES[name]
    loss, td = factory()
    critic = resolve_param_group(loss, "critic")
    every = resolve_param_group(loss, "all")
    ids = {id(p) for p in critic}
    rest = [p for p in every if id(p) not in ids]
    wrapper = {"pcgrad": lambda: PCGrad(loss, K, seed=5), "cagrad": lambda: CAGrad(loss, K),
               "famo": lambda: FAMO(loss, K)}[method]()
    if method == "famo":
        wrapper.famo_logits.copy_(torch.tensor([0.3, -0.2, 0.1]))
    logits = wrapper.famo_logits.clone() if method == "famo" else None
    torch.manual_seed(11)
    metrics = compute_gradients(wrapper, td.clone())
    got_critic = grads_of(critic)
    got_rest = grads_of(rest) if rest else None
    # laid out like the parameters, as backward() does (the twin-Q ensemble's weight gradients come out of the
    # batched backward transposed; CUDA's fused Adam refuses grads strided unlike their parameters)
    assert [p.grad.stride() for p in every if p.grad is not None] == [p.stride() for p in every if p.grad is not None]
    for p in every:
        p.grad = None
    g = reference_task_grads(loss, td, critic_terms, critic, seed=11)
    assert bool(((g @ g.T) < 0).any()), "the test needs conflicting per-task critic gradients"
    if method == "pcgrad":
        expected = pcgrad(g, orders=random_task_orders(K, torch.Generator().manual_seed(5), "cpu"))
    elif method == "cagrad":
        expected = K * cagrad(g, c=0.4)  # scale_by_num_tasks (MTBench)
    else:
        task_loss = metrics[f"task_{critic_terms[0]}"]
        expected = famo_loss_coefficients(task_loss, logits, epsilon=1e-2) @ g
    assert torch.allclose(got_critic, expected, atol=1e-5), (name, method)
    if got_rest is not None:  # every other parameter: the plain batch-mean gradient of all terms (params="critic")
        assert torch.allclose(got_rest, plain_grads(loss, td, rest, seed=11), atol=1e-5)
    assert all(torch.isfinite(p.grad).all() for p in every if p.grad is not None)


def test_pcgrad_and_cagrad_known_answer_through_a_dqn_style_loss():
    """Two tasks whose per-task gradients are exactly g1 = (1, 0) and g2 = (-1, 1) (a linear ``loss``):
    PCGrad mean (0.25, 0.75), CAGrad (0.172414, 0.431034) (c = 0.4, rescale 1)."""

    class Linear(DQNStyleLoss):
        def forward(self, td):
            loss = td["x"] @ self.value_network.weight.squeeze(0)  # per sample w . x_i
            return TensorDict({"loss": loss if self.reduction == "none" else loss.mean()}, [])

    x = torch.tensor([[1.0, 0.0], [1.0, 0.0], [-1.0, 1.0], [-1.0, 1.0]])
    td = TensorDict({"x": x, "task_id": torch.tensor([0, 0, 1, 1])}, [4])
    for wrapper_cls, kwargs, expected in (
        (PCGrad, {"seed": 0}, [0.25, 0.75]),
        (CAGrad, {"scale_by_num_tasks": False}, [0.172414, 0.431034]),
    ):
        loss = Linear(nn.Linear(2, 1, bias=False))
        wrapper = wrapper_cls(loss, 2, **kwargs)
        wrapper.backward(td)
        assert torch.allclose(loss.value_network.weight.grad.squeeze(0), torch.tensor(expected), atol=1e-5)


def test_terms_reaching_neither_group_are_never_manipulated():
    """SAC's temperature loss reaches neither the actor nor the Q networks: with params="critic" it is a plain term
    (its gradient on log_alpha is the batch-mean one), with params="actor" too."""
    loss, td = mt_sac()
    for params in ("critic", "actor"):
        wrapper = PCGrad(loss, K, params=params)
        loss.log_alpha.grad = None
        torch.manual_seed(1)
        wrapper.backward(td.clone())
        got = loss.log_alpha.grad.clone()
        torch.manual_seed(1)
        out = loss(td.clone())
        (expected,) = torch.autograd.grad(out["loss_alpha"].mean(), [loss.log_alpha])
        assert torch.allclose(got, expected, atol=1e-6), params
    dqn_loss, dqn_td = dqn()
    dqn_loss.actor_network = nn.Linear(1, 1)  # an actor network that no loss term reaches
    with pytest.raises(ValueError, match="params='actor' needs a loss term whose graph reaches the actor parameters"):
        PCGrad(dqn_loss, K, params="actor").backward(dqn_td)
