"""Gradient manipulation wrappers (PCGrad, CAGrad, FAMO, diagnostics): known answers and invariants.

Known answers: /work/shared/reference/mtrl-algorithms.md section 3 ([verified] values).
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf
from tensordict import TensorDict
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator
from torchrl.objectives import ClipPPOLoss, LossModule

from host_sync import forbid_host_sync
from mtbench.objectives import (
    CAGrad,
    DIAGNOSTIC_KEYS,
    FAMO,
    GradientDiagnostics,
    PCGrad,
    cagrad,
    cagrad_weights,
    compute_gradients,
    cosine_stats,
    make_gradient_method,
    pcgrad,
    pcgrad_weights,
    per_task_gradients,
    resolve_param_group,
    task_means,
    total_loss,
)
from mtbench.objectives.cagrad import cagrad_objective, project_simplex
from mtbench.objectives.famo import famo_logit_gradient, famo_loss_coefficients
from mtbench.objectives.pcgrad import random_task_orders
from mtbench.objectives.task_gradients import flatten

CONF_GRAD = Path(__file__).resolve().parents[1] / "conf" / "grad"
OBS, ACT = 6, 2


# ---------------------------------------------------------------------------------------------- fixtures
def make_actor_critic(seed: int = 0) -> tuple[ProbabilisticActor, ValueOperator]:
    torch.manual_seed(seed)
    net = nn.Sequential(nn.Linear(OBS, 16), nn.Tanh(), nn.Linear(16, 2 * ACT), NormalParamExtractor())
    actor = ProbabilisticActor(
        TensorDictModule(net, ["observation"], ["loc", "scale"]),
        in_keys=["loc", "scale"],
        distribution_class=TanhNormal,
        return_log_prob=True,
    )
    critic = ValueOperator(nn.Sequential(nn.Linear(OBS, 16), nn.Tanh(), nn.Linear(16, 1)), in_keys=["observation"])
    return actor, critic


def make_loss(seed: int = 0, **kwargs) -> ClipPPOLoss:
    actor, critic = make_actor_critic(seed)
    return ClipPPOLoss(actor, critic, **kwargs)


def make_batch(actor, task_id: torch.Tensor, seed: int = 1) -> TensorDict:
    g = torch.Generator().manual_seed(seed)
    n = task_id.shape[0]
    td = TensorDict(
        {"observation": torch.randn(n, OBS, generator=g), "task_id": task_id}, batch_size=[n]
    )
    with torch.no_grad():
        actor(td)
    # task-dependent targets so that the per-task gradients differ and conflict (odd tasks: opposite sign)
    tid = task_id.reshape(n, 1).float()
    sign = 1.0 - 2.0 * (tid % 2)
    td["advantage"] = torch.randn(n, 1, generator=g) + sign * (1 + tid)
    td["value_target"] = torch.randn(n, 1, generator=g) + 3.0 * sign * (1 + tid)
    return td


def zero_grads(module: nn.Module) -> None:
    for p in module.parameters():
        p.grad = None


def grads_of(params) -> torch.Tensor:
    return flatten([p.grad if p.grad is not None else torch.zeros_like(p) for p in params])


def loop_task_grads(loss: ClipPPOLoss, td: TensorDict, terms: list[str], params, num_tasks: int, seed: int):
    """Reference: per-task masked-mean losses, one backward pass per task (fresh forward each time)."""
    rows = []
    for k in range(num_tasks):
        torch.manual_seed(seed)
        out = loss(td)
        per_sample = sum(out[t] for t in terms).reshape(-1)
        mask = td["task_id"].reshape(-1) == k
        if not bool(mask.any()):
            rows.append(torch.zeros(sum(p.numel() for p in params)))
            continue
        task_loss = per_sample[mask].mean()
        gs = torch.autograd.grad(task_loss, params, allow_unused=True)
        rows.append(flatten([torch.zeros_like(p) if g is None else g for p, g in zip(params, gs, strict=True)]))
    return torch.stack(rows)


def balanced_ids(num_tasks: int, per_task: int, trailing: bool = False) -> torch.Tensor:
    ids = torch.arange(num_tasks).repeat_interleave(per_task)
    ids = ids[torch.randperm(ids.numel(), generator=torch.Generator().manual_seed(3))]
    return ids[:, None] if trailing else ids


# ---------------------------------------------------------------------------------------------- per-task losses
def test_task_means_known_values_weights_and_absent_tasks():
    values = torch.tensor([1.0, 2.0, 3.0, 4.0, 10.0], requires_grad=True)
    ids = torch.tensor([0, 0, 2, 2, 0])
    means, counts = task_means(values, ids, 4)
    assert torch.allclose(means, torch.tensor([13.0 / 3, 0.0, 3.5, 0.0]))
    assert torch.equal(counts, torch.tensor([3.0, 0.0, 2.0, 0.0]))
    weights = torch.tensor([True, True, True, False, False])
    wmeans, wcounts = task_means(values, ids, 4, weights=weights)
    assert torch.allclose(wmeans, torch.tensor([1.5, 0.0, 3.0, 0.0]))
    assert torch.equal(wcounts, torch.tensor([2.0, 0.0, 1.0, 0.0]))
    wmeans.sum().backward()
    assert torch.allclose(values.grad, torch.tensor([0.5, 0.5, 1.0, 0.0, 0.0]))
    two = torch.stack([values.detach(), 2 * values.detach()], -1)
    m2, _ = task_means(two, ids, 4)
    assert torch.allclose(m2[:, 1], 2 * m2[:, 0])


def test_wrapper_forward_per_task_metrics_with_trailing_task_dim():
    loss = make_loss()
    ids = balanced_ids(3, 20, trailing=True)
    td = make_batch(loss.actor_network, ids)
    wrapper = PCGrad(loss, 3)
    assert loss.reduction == "none"
    torch.manual_seed(0)
    out = wrapper(td)
    torch.manual_seed(0)
    raw = loss(td)
    for name in ("loss_objective", "loss_critic", "loss_entropy"):
        assert out[name].shape == ()
        assert torch.allclose(out[name], raw[name].mean(), atol=1e-6)
        per_task = torch.stack([raw[name].reshape(-1)[ids.reshape(-1) == k].mean() for k in range(3)])
        assert torch.allclose(out[f"task_{name}"], per_task, atol=1e-6)
    assert torch.equal(out["task_count"], torch.full((3,), 20.0))
    assert out["loss_critic"].requires_grad  # forward keeps the graph (usable as a plain loss)


# ---------------------------------------------------------------------------------------------- PCGrad
def test_pcgrad_known_answer():
    g = torch.tensor([[1.0, 0.0], [-1.0, 1.0]])
    orders = torch.tensor([[0, 1], [1, 0]])
    assert torch.allclose(pcgrad(g, orders=orders, reduction="mean"), torch.tensor([0.25, 0.75]))
    assert torch.allclose(pcgrad(g, orders=orders, reduction="sum"), torch.tensor([0.5, 1.5]))
    # individual projected gradients (0.5, 0.5) and (0, 1), orthogonal to the other task's gradient
    present = torch.ones(2, dtype=torch.bool)
    lam_sum = pcgrad_weights(g @ g.T, present, orders, "sum")
    assert torch.allclose(lam_sum @ g, torch.tensor([0.5, 1.5]))
    g1_pc = torch.tensor([1.0, 0.0]) - (-1.0 / 2.0) * torch.tensor([-1.0, 1.0])
    g2_pc = torch.tensor([-1.0, 1.0]) - (-1.0 / 1.0) * torch.tensor([1.0, 0.0])
    assert torch.allclose(g1_pc, torch.tensor([0.5, 0.5])) and torch.allclose(g2_pc, torch.tensor([0.0, 1.0]))
    assert torch.allclose(g1_pc + g2_pc, lam_sum @ g)
    assert abs(float(g1_pc @ g[1])) < 1e-7 and abs(float(g2_pc @ g[0])) < 1e-7


def naive_pcgrad(g: torch.Tensor, orders: torch.Tensor, present: torch.Tensor, reduction: str) -> torch.Tensor:
    out = []
    for i in range(g.shape[0]):
        if not present[i]:
            continue
        gi = g[i].clone()
        for j in orders[i].tolist():
            if j == i or not present[j]:
                continue
            dot = gi @ g[j]
            if dot < 0:
                gi = gi - dot / (g[j] @ g[j]) * g[j]
        out.append(gi)
    stacked = torch.stack(out)
    return stacked.mean(0) if reduction == "mean" else stacked.sum(0)


@pytest.mark.parametrize("reduction", ["mean", "sum"])
def test_pcgrad_gram_form_matches_naive_projection(reduction):
    gen = torch.Generator().manual_seed(0)
    for k in (3, 5, 8):
        g = torch.randn(k, 11, generator=gen, dtype=torch.float64) + 0.3
        present = torch.ones(k, dtype=torch.bool)
        present[1] = k != 8  # one absent task in the K=8 case
        g[~present] = 0
        orders = random_task_orders(k, gen, "cpu")
        expected = naive_pcgrad(g, orders, present, reduction)
        assert torch.allclose(pcgrad(g, present, orders=orders, reduction=reduction), expected, atol=1e-10)


def test_pcgrad_no_conflict_is_plain_mean():
    g = torch.tensor([[1.0, 0.5, 0.0], [0.2, 1.0, 0.1], [0.3, 0.1, 2.0]])
    assert torch.all(g @ g.T >= 0)
    assert torch.allclose(pcgrad(g, generator=torch.Generator().manual_seed(0)), g.mean(0))
    assert torch.allclose(pcgrad(g, reduction="sum", generator=torch.Generator().manual_seed(0)), g.sum(0))


# ---------------------------------------------------------------------------------------------- CAGrad
CAGRAD_TABLE = [
    # G rows, w*, d (unscaled), d / (1 + 0.16)
    ([[1.0, 0.0], [-1.0, 1.0]], [1.0, 0.0], [0.2, 0.5], [0.172414, 0.431034]),
    ([[1.0, 0.0], [0.0, 1.0]], [0.5, 0.5], [0.7, 0.7], [0.603448, 0.603448]),
    ([[2.0, 0.0], [-1.0, 0.5]], [0.0, 1.0], [0.3, 0.35], [0.258621, 0.301724]),
]


@pytest.mark.parametrize("rows,w_star,d,d_scaled", CAGRAD_TABLE)
def test_cagrad_reference_table(rows, w_star, d, d_scaled):
    g = torch.tensor(rows)
    w = cagrad_weights(g @ g.T, c=0.4)
    assert torch.allclose(w.float(), torch.tensor(w_star), atol=1e-5)
    d0 = cagrad(g, c=0.4, rescale=0)
    assert torch.allclose(d0, torch.tensor(d), atol=1e-5)
    assert torch.allclose(cagrad(g, c=0.4), torch.tensor(d_scaled), atol=1e-5)
    assert torch.allclose(cagrad(g, c=0.4, rescale=2), torch.tensor(d) / 1.4, atol=1e-5)
    g0 = g.mean(0)
    radius = 0.4 * float(torch.linalg.vector_norm(g0))
    assert math.isclose(float(torch.linalg.vector_norm(d0 - g0)), radius, rel_tol=1e-4)  # on the ball


def test_cagrad_c_zero_is_mean():
    g = torch.randn(5, 9, generator=torch.Generator().manual_seed(0))
    assert torch.allclose(cagrad(g, c=0.0), g.mean(0))
    present = torch.tensor([True, False, True, True, False])
    assert torch.allclose(cagrad(g, present, c=0.0), g[present].mean(0))


def _slsqp_weights(a: np.ndarray, c: float) -> np.ndarray:
    from scipy.optimize import minimize

    k = a.shape[0]
    u0 = np.full(k, 1.0 / k)
    b = a @ u0
    g0_norm = math.sqrt(float(u0 @ a @ u0) + 1e-8)

    def objective(x):
        return float(x @ b + c * g0_norm * math.sqrt(float(x @ a @ x) + 1e-8))

    res = minimize(
        objective,
        u0,
        bounds=[(0.0, 1.0)] * k,
        constraints={"type": "eq", "fun": lambda x: 1.0 - x.sum()},
        method="SLSQP",
    )
    return res.x


def test_cagrad_device_solver_matches_scipy_slsqp():
    pytest.importorskip("scipy")
    rng = np.random.default_rng(0)
    for trial in range(40):
        k = int(rng.integers(3, 11))
        p = int(rng.choice([20, 100]))
        common = rng.normal(size=p) * rng.uniform(0.0, 2.0)  # correlated task gradients, as in practice
        g = rng.normal(size=(k, p)) * rng.uniform(0.1, 3.0, size=(k, 1)) + common
        a = g @ g.T
        w_ref = _slsqp_weights(a, 0.4)
        gt = torch.tensor(g)
        w = cagrad_weights(torch.tensor(a), c=0.4).numpy()
        assert abs(w.sum() - 1) < 1e-9 and (w >= 0).all()
        at = torch.tensor(a / np.abs(a).max())
        u0 = torch.full((k,), 1.0 / k, dtype=torch.float64)
        rho = 0.4 * (u0 @ at @ u0).sqrt()
        f_ours = float(cagrad_objective(torch.tensor(w), at, at @ u0, rho))
        f_ref = float(cagrad_objective(torch.tensor(w_ref), at, at @ u0, rho))
        assert f_ours <= f_ref + 1e-7, (trial, f_ours, f_ref)
        g0 = g.mean(0)
        gw_ref = w_ref @ g
        d_ref = g0 + 0.4 * np.linalg.norm(g0) / np.linalg.norm(gw_ref) * gw_ref
        d = cagrad(gt, c=0.4, rescale=0).numpy()
        assert np.abs(d - d_ref).max() <= 2e-3 * np.abs(d_ref).max(), trial


def test_cagrad_solver_excludes_absent_tasks_and_projects_onto_simplex():
    g = torch.randn(4, 7, generator=torch.Generator().manual_seed(2), dtype=torch.float64)
    present = torch.tensor([True, True, False, True])
    full = cagrad(g[present], c=0.4)
    g_abs = g.clone()
    g_abs[2] = 0
    assert torch.allclose(cagrad(g_abs, present, c=0.4), full, atol=1e-8)
    w = cagrad_weights(g_abs @ g_abs.T, present, c=0.4)
    assert float(w[2]) == 0.0
    v = torch.tensor([[0.3, 2.0, -1.0, 0.5], [5.0, 5.0, 5.0, 5.0]], dtype=torch.float64)
    proj = project_simplex(v, present)
    assert torch.allclose(proj.sum(-1), torch.ones(2, dtype=torch.float64)) and torch.all(proj[:, 2] == 0)
    assert torch.allclose(proj[1], torch.tensor([1 / 3, 1 / 3, 0, 1 / 3], dtype=torch.float64))


# ---------------------------------------------------------------------------------------------- FAMO
def test_famo_logit_gradient_and_one_adam_step():
    d = famo_logit_gradient(torch.zeros(2), torch.tensor([1.0, 0.0]), normalize=False)
    assert torch.allclose(d, torch.tensor([0.25, -0.25]))
    assert torch.allclose(famo_logit_gradient(torch.zeros(3), torch.full((3,), 0.7)), torch.zeros(3))
    famo = FAMO(make_loss(), 2, w_lr=1e-3, gamma=1e-3)
    losses = torch.tensor([1.0, 1.0])
    famo.famo_prev_log_loss.copy_(torch.log(losses + 1e-2) + torch.tensor([1.0, 0.0]))  # -> delta = (1, 0)
    famo.update_logits(losses)
    assert torch.allclose(famo.famo_logits, torch.tensor([-1e-3, 1e-3]), atol=1e-8)
    assert torch.allclose(famo.task_weights, torch.tensor([0.4995, 0.5005]), atol=1e-6)  # toward task 2


def test_famo_adam_matches_torch_adam():
    famo = FAMO(make_loss(), 4, w_lr=0.05, gamma=0.01)
    ref = torch.zeros(4, requires_grad=True)
    opt = torch.optim.Adam([ref], lr=0.05, weight_decay=0.01)
    gen = torch.Generator().manual_seed(0)
    for _ in range(6):
        grad = torch.randn(4, generator=gen)
        famo._adam_step(grad)
        ref.grad = grad.clone()
        opt.step()
    assert torch.allclose(famo.famo_logits, ref.detach(), atol=1e-6)


def test_famo_loss_coefficients_sum_to_one_and_match_autograd():
    losses = torch.tensor([0.5, 2.0], requires_grad=True)
    logits = torch.log(torch.tensor([0.3, 0.7]))
    lam = famo_loss_coefficients(losses.detach(), logits, epsilon=1e-2)
    assert torch.allclose(lam, torch.tensor([0.6281, 0.3719]), atol=1e-4)
    assert math.isclose(float(lam.sum()), 1.0, rel_tol=1e-6)
    z = torch.softmax(logits, -1)
    dk = losses + 1e-2
    c = (z / dk).sum().detach()
    (z * dk.log() / c).sum().backward()
    assert torch.allclose(losses.grad, lam, atol=1e-6)
    gen = torch.Generator().manual_seed(0)
    present = torch.tensor([True, False, True, True, True])
    lam5 = famo_loss_coefficients(torch.rand(5, generator=gen), torch.randn(5, generator=gen), present)
    assert math.isclose(float(lam5.sum()), 1.0, rel_tol=1e-6) and float(lam5[1]) == 0.0


def test_famo_backward_is_weighted_sum_without_per_task_gradients(monkeypatch):
    import mtbench.objectives.task_wrapper as tw

    def forbidden(*args, **kwargs):
        raise AssertionError("FAMO must not compute per-task gradients")

    monkeypatch.setattr(tw, "per_task_gradients", forbidden)
    loss = make_loss()
    k = 3
    ids = balanced_ids(k, 16)
    td = make_batch(loss.actor_network, ids)
    famo = FAMO(loss, k)
    famo.famo_logits.copy_(torch.tensor([0.2, -0.1, 0.4]))
    logits_before = famo.famo_logits.clone()
    critic = resolve_param_group(loss, "critic")
    actor = resolve_param_group(loss, "actor")
    torch.manual_seed(5)
    metrics = compute_gradients(famo, td)
    got_critic, got_actor = grads_of(critic), grads_of(actor)
    # reference: per-task critic gradients by loop, weighted with FAMO's coefficients
    g = loop_task_grads(loss, td, ["loss_critic"], critic, k, seed=5)
    lam = famo_loss_coefficients(metrics["task_loss_critic"], logits_before, epsilon=1e-2)
    assert torch.allclose(got_critic, lam @ g, atol=1e-6)
    zero_grads(loss)
    loss.reduction = "mean"
    torch.manual_seed(5)
    out = loss(td)
    (out["loss_objective"] + out["loss_entropy"]).backward()
    assert torch.allclose(got_actor, grads_of(actor), atol=1e-6)
    assert not torch.equal(famo.famo_logits, logits_before)  # the weight step ran
    assert metrics["famo_weight"].shape == (k,)


def test_famo_state_dict_restores_logits_and_optimizer_state():
    loss = make_loss()
    td = make_batch(loss.actor_network, balanced_ids(3, 10))
    a = FAMO(loss, 3)
    for _ in range(3):
        torch.manual_seed(0)
        a.backward(td)
    state = a.state_dict()
    for key in ("famo_logits", "famo_exp_avg", "famo_exp_avg_sq", "famo_step", "famo_prev_log_loss"):
        assert key in state
    b = FAMO(make_loss(seed=7), 3)
    b.load_state_dict(state)
    assert torch.equal(b.famo_logits, a.famo_logits) and float(b.famo_step) == 3.0
    losses = torch.tensor([0.3, 0.2, 0.9])
    a.update_logits(losses)
    b.update_logits(losses)
    assert torch.equal(a.famo_logits, b.famo_logits)


# ---------------------------------------------------------------------------------------------- batched gradients
def test_batched_per_task_gradients_equal_loop_on_clip_ppo_loss():
    loss = make_loss(reduction="none")
    k = 4
    ids = balanced_ids(k, 12)
    td = make_batch(loss.actor_network, ids)
    for group, terms in (("critic", ["loss_critic"]), ("actor", ["loss_objective", "loss_entropy"])):
        params = resolve_param_group(loss, group)
        torch.manual_seed(3)
        out = loss(td)
        per_sample = sum(out[t] for t in terms)
        task_losses, _ = task_means(per_sample, ids, k)
        batched = per_task_gradients(task_losses, params)
        loop = per_task_gradients(task_losses, params, batched=False)
        assert batched.shape == (k, sum(p.numel() for p in params))
        assert torch.allclose(batched, loop, atol=1e-6)
        ref = loop_task_grads(loss, td, terms, params, k, seed=3)  # independent per-task backward passes
        assert torch.allclose(batched, ref, atol=1e-6)


# ---------------------------------------------------------------------------------------------- wrappers
def test_pcgrad_wrapper_critic_only_and_actor_plain_mean():
    loss = make_loss()
    k = 3
    ids = balanced_ids(k, 16)
    td = make_batch(loss.actor_network, ids)
    wrapper = PCGrad(loss, k, seed=11)
    critic, actor = resolve_param_group(loss, "critic"), resolve_param_group(loss, "actor")
    torch.manual_seed(2)
    compute_gradients(wrapper, td)
    got_critic, got_actor = grads_of(critic), grads_of(actor)
    g = loop_task_grads(loss, td, ["loss_critic"], critic, k, seed=2)
    assert bool(((g @ g.T) < 0).any())  # conflicting critic gradients: PCGrad changes something
    orders = random_task_orders(k, torch.Generator().manual_seed(11), "cpu")
    expected = pcgrad(g, orders=orders)
    assert torch.allclose(got_critic, expected, atol=1e-6)
    # actor: the plain batch-mean gradient of the actor terms (what reduction="mean" would give)
    zero_grads(loss)
    loss.reduction = "mean"
    torch.manual_seed(2)
    out = loss(td)
    total_loss(out).backward()
    assert torch.allclose(got_actor, grads_of(actor), atol=1e-6)
    assert not torch.allclose(got_critic, grads_of(critic), atol=1e-4)  # the critic gradient was changed


def test_failed_batched_backward_is_not_retried(monkeypatch):
    """Where the batched backward has no batching rule (e.g. compiled networks), the wrapper warns once, uses K
    passes and does not retry the batched pass at later updates; the gradients are those of the batched path."""
    k = 3
    ids = balanced_ids(k, 16)
    reference = make_loss()
    torch.manual_seed(2)
    compute_gradients(PCGrad(reference, k, seed=11), make_batch(reference.actor_network, ids))
    expected = grads_of(resolve_param_group(reference, "critic"))

    real_grad = torch.autograd.grad
    batched_calls = []

    def no_batching_rule(*args, **kwargs):
        if kwargs.get("is_grads_batched"):
            batched_calls.append(1)
            raise RuntimeError("Batching rule not implemented for aten::mm.out")
        return real_grad(*args, **kwargs)

    monkeypatch.setattr(torch.autograd, "grad", no_batching_rule)
    monkeypatch.setattr("mtbench.objectives.task_gradients._BATCHED_FALLBACK_WARNED", False)
    loss = make_loss()
    wrapper = PCGrad(loss, k, seed=11)
    td = make_batch(loss.actor_network, ids)
    torch.manual_seed(2)
    with pytest.warns(RuntimeWarning, match="separate backward passes"):
        compute_gradients(wrapper, td)
    assert torch.allclose(grads_of(resolve_param_group(loss, "critic")), expected, atol=1e-6)
    assert wrapper.batched_backward is False and len(batched_calls) == 1
    zero_grads(loss)
    compute_gradients(wrapper, td)
    assert len(batched_calls) == 1  # not retried


def test_params_all_and_actor_groups():
    k = 3
    loss = make_loss()
    ids = balanced_ids(k, 16)
    td = make_batch(loss.actor_network, ids)
    every = resolve_param_group(loss, "all")
    torch.manual_seed(4)
    CAGrad(loss, k, params="all", scale_by_num_tasks=False).backward(td)
    got = grads_of(every)
    g = loop_task_grads(loss, td, ["loss_objective", "loss_entropy", "loss_critic"], every, k, seed=4)
    assert torch.allclose(got, cagrad(g, c=0.4), atol=1e-5)

    zero_grads(loss)
    critic, actor = resolve_param_group(loss, "critic"), resolve_param_group(loss, "actor")
    torch.manual_seed(4)
    CAGrad(loss, k, params="actor", c=0.0, scale_by_num_tasks=False).backward(td)
    got_critic, got_actor = grads_of(critic), grads_of(actor)
    g_actor = loop_task_grads(loss, td, ["loss_objective", "loss_entropy"], actor, k, seed=4)
    assert torch.allclose(got_actor, g_actor.mean(0), atol=1e-6)  # c = 0: mean of per-task gradients
    zero_grads(loss)
    loss.reduction = "mean"
    torch.manual_seed(4)
    loss(td)["loss_critic"].backward()
    assert torch.allclose(got_critic, grads_of(critic), atol=1e-6)


def test_cagrad_scale_by_num_tasks():
    k = 3
    ids = balanced_ids(k, 10)
    results = []
    for scale in (False, True):
        loss = make_loss()
        td = make_batch(loss.actor_network, ids)
        torch.manual_seed(0)
        CAGrad(loss, k, scale_by_num_tasks=scale).backward(td)
        results.append(grads_of(resolve_param_group(loss, "critic")))
    assert torch.allclose(results[1], k * results[0], atol=1e-6)


@pytest.mark.parametrize("method", ["pcgrad", "cagrad"])
def test_absent_task_is_excluded(method):
    ids3 = torch.tensor([0, 2] * 12)  # task 1 absent from the minibatch
    ids2 = torch.where(ids3 == 2, 1, ids3)
    grads = []
    for k, ids in ((3, ids3), (2, ids2)):
        loss = make_loss()
        td = make_batch(loss.actor_network, ids3)  # same data; only the task numbering differs
        td["task_id"] = ids
        wrapper = make_gradient_method(method, loss, k, diagnostics_every=1)
        torch.manual_seed(0)
        metrics = wrapper.backward(td)
        grads.append(grads_of(resolve_param_group(loss, "all")))
        assert torch.all(torch.isfinite(grads[-1]))
        if k == 3:
            assert torch.equal(metrics["task_count"], torch.tensor([12.0, 0.0, 12.0]))
            cos3 = {key: metrics[key] for key in DIAGNOSTIC_KEYS}
        else:
            cos2 = {key: metrics[key] for key in DIAGNOSTIC_KEYS}
    assert torch.allclose(grads[0], grads[1], atol=1e-6)
    for key in DIAGNOSTIC_KEYS:  # one pair of present tasks in both cases
        assert torch.allclose(cos3[key], cos2[key], atol=1e-5)


# ---------------------------------------------------------------------------------------------- diagnostics
def test_cosine_stats_hand_computation():
    g = torch.tensor([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [5.0, 5.0]])
    present = torch.tensor([True, True, True, False])
    stats = cosine_stats(g @ g.T, present)
    s = 1 / math.sqrt(2)
    assert torch.allclose(stats, torch.tensor([(0 + s + s) / 3, 0.0, s]), atol=1e-6)
    only_one = cosine_stats(g @ g.T, torch.tensor([True, False, False, False]))
    assert torch.all(torch.isnan(only_one))


def test_diagnostics_match_hand_computation_and_keep_gradients():
    k = 4
    loss = make_loss()
    ids = balanced_ids(k, 10)
    td = make_batch(loss.actor_network, ids)
    diag = make_gradient_method("none", loss, k, diagnostics_every=2)
    assert isinstance(diag, GradientDiagnostics)
    torch.manual_seed(9)
    metrics = compute_gradients(diag, td)
    got = grads_of(resolve_param_group(loss, "all"))
    for group, terms in (("actor", ["loss_objective", "loss_entropy"]), ("critic", ["loss_critic"])):
        params = resolve_param_group(loss, group)
        g = loop_task_grads(loss, td, terms, params, k, seed=9)
        cos = [
            torch.nn.functional.cosine_similarity(g[i], g[j], dim=0) for i in range(k) for j in range(i + 1, k)
        ]
        cos = torch.stack(cos)
        assert torch.allclose(metrics[f"grad_cos_{group}_mean"], cos.mean(), atol=1e-5)
        assert torch.allclose(metrics[f"grad_cos_{group}_min"], cos.min(), atol=1e-5)
        assert torch.allclose(metrics[f"grad_cos_{group}_max"], cos.max(), atol=1e-5)
    # gradients unchanged: the plain summed batch-mean loss
    zero_grads(loss)
    loss.reduction = "mean"
    torch.manual_seed(9)
    total_loss(loss(td)).backward()
    assert torch.allclose(got, grads_of(resolve_param_group(loss, "all")), atol=1e-6)
    # every=2: update 1 reuses the last measurement, update 2 measures again
    loss.reduction = "none"
    first = metrics["grad_cos_critic_mean"].clone()
    td2 = make_batch(loss.actor_network, ids, seed=5)
    m1 = diag.backward(td2)
    assert torch.equal(m1["grad_cos_critic_mean"], first)
    m2 = diag.backward(td2)
    assert not torch.equal(m2["grad_cos_critic_mean"], first)


# ---------------------------------------------------------------------------------------------- factory / config
def test_factory_names_and_errors():
    loss = make_loss(reduction="none")
    with pytest.raises(ValueError, match="valid choices.*cagrad.*famo.*none.*pcgrad"):
        make_gradient_method("mgda", loss, 3)
    same = make_gradient_method("none", loss, 3)
    assert same is loss and loss.reduction == "mean"
    assert isinstance(make_gradient_method("pcgrad", loss, 3), PCGrad) and loss.reduction == "none"
    with pytest.raises(ValueError, match="params"):
        make_gradient_method("cagrad", make_loss(), 3, params="value")
    with pytest.raises(ValueError, match="invalid arguments"):
        make_gradient_method("famo", make_loss(), 3, c=0.4)


@pytest.mark.parametrize("name", ["none", "pcgrad", "cagrad", "famo"])
def test_hydra_grad_configs_build(name):
    cfg = OmegaConf.to_container(OmegaConf.load(CONF_GRAD / f"{name}.yaml"), resolve=True)
    assert cfg["name"] == name and cfg["params"] == "critic" and "diagnostics_every" in cfg
    loss = make_loss()
    module = make_gradient_method(cfg.pop("name"), loss, 3, **cfg)
    expected = {"none": ClipPPOLoss, "pcgrad": PCGrad, "cagrad": CAGrad, "famo": FAMO}[name]
    assert isinstance(module, expected)
    if name == "cagrad":
        assert module.c == 0.4 and module.rescale == 1 and module.scale_by_num_tasks
    if name == "famo":
        assert (module.gamma, module.w_lr, module.epsilon, module.norm_w_grad) == (1e-3, 1e-3, 1e-2, True)
    td = make_batch(loss.actor_network, balanced_ids(3, 8))
    metrics = compute_gradients(module, td)
    assert torch.isfinite(total_loss(metrics))
    assert all(p.grad is not None for p in loss.parameters())


def test_param_group_and_inner_loss_errors():
    with pytest.raises(ValueError, match="valid choices"):
        resolve_param_group(make_loss(), "trunk")

    class ActorOnly(nn.Module):
        def __init__(self):
            super().__init__()
            self.actor_network = nn.Linear(2, 2)

    with pytest.raises(ValueError, match="no critic network"):
        resolve_param_group(ActorOnly(), "critic")

    class ScalarLoss(LossModule):
        def __init__(self):
            super().__init__()
            self.actor_network = nn.Linear(2, 1)
            self.critic_network = nn.Linear(2, 1)

        def forward(self, td):
            x = td["x"]
            return TensorDict(
                {"loss_a": self.actor_network(x).mean(), "loss_critic": self.critic_network(x).pow(2).mean()}, []
            )

    td = TensorDict({"x": torch.randn(6, 2), "task_id": torch.tensor([0, 1, 0, 1, 0, 1])}, [6])
    with pytest.raises(ValueError, match="reduction='none'"):
        PCGrad(ScalarLoss(), 2).backward(td)
    with pytest.raises(KeyError, match="task_id"):
        PCGrad(make_loss(), 2).backward(td.exclude("task_id"))
    with pytest.raises(ValueError, match=r"task_id values must lie in \[0, 2\)"):
        loss = make_loss()
        PCGrad(loss, 2).backward(make_batch(loss.actor_network, torch.tensor([0, 1, 2, 0])))


def test_wrappers_on_mtbench_mt_ppo_loss():
    from mtbench.objectives import MTPPOLoss
    from mtbench.trainer.actor_critic import make_actor, make_critic

    k, state, n = 3, 5, 48
    arch = {"name": "mlp", "kwargs": {"hidden": [16, 16]}}
    torch.manual_seed(0)
    actor = make_actor(arch, obs_dim=state + k, action_dim=2, num_tasks=k)
    critic = make_critic(arch, obs_dim=state + k, num_tasks=k)
    loss = MTPPOLoss(actor, critic, num_tasks=k)
    ids = balanced_ids(k, n // k)
    obs = torch.cat([torch.randn(n, state), torch.nn.functional.one_hot(ids, k).float()], -1)
    td = TensorDict({"observation": obs, "task_id": ids}, [n])
    with torch.no_grad():
        actor(td)
    td["advantage"] = torch.randn(n, 1)
    td["value_target"] = torch.randn(n, 1) + 3 * (ids[:, None] % 2)
    td["state_value"] = td["value_target"] + 0.05 * torch.randn(n, 1)
    actor_params = resolve_param_group(loss, "actor")
    loss.reduction = "mean"
    total_loss(loss(td)).backward()
    plain_actor = grads_of(actor_params)
    for name in ("pcgrad", "cagrad", "famo"):
        zero_grads(loss)
        module = make_gradient_method(name, loss, k, diagnostics_every=1)
        metrics = compute_gradients(module, td)
        assert {"loss_objective", "loss_critic", "loss_entropy", "loss_bounds", "kl"} <= set(metrics.keys())
        assert all(metrics[key].shape == () for key in DIAGNOSTIC_KEYS)
        assert torch.allclose(grads_of(actor_params), plain_actor, atol=1e-6)  # params="critic"
        assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in loss.parameters())


class _QuadraticLoss(LossModule):
    """Sync-free per-sample actor/critic loss (TorchRL's TanhNormal itself converts tensors to bools)."""

    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.actor_network = nn.Sequential(nn.Linear(OBS, 8), nn.Tanh(), nn.Linear(8, ACT))
        self.critic_network = nn.Sequential(nn.Linear(OBS, 8), nn.Tanh(), nn.Linear(8, 1))
        self.reduction = "mean"

    def forward(self, td):
        obs = td["observation"]
        terms = {
            "loss_objective": -(self.actor_network(obs) * td["advantage"]).sum(-1),
            "loss_critic": (self.critic_network(obs) - td["value_target"]).pow(2).squeeze(-1),
        }
        if self.reduction == "mean":
            terms = {k: v.mean() for k, v in terms.items()}
        return TensorDict(terms, batch_size=[])


@pytest.mark.parametrize("method", ["none", "pcgrad", "cagrad", "famo"])
def test_backward_has_no_host_sync(monkeypatch, method):
    """No tensor -> Python conversion in the wrappers' backward (the calls that would sync a GPU)."""
    import mtbench.objectives.task_wrapper as tw

    loss = _QuadraticLoss()
    ids = torch.tensor([0, 2] * 10)  # task 1 absent
    sign = torch.where(ids == 2, -1.0, 1.0)[:, None]  # conflicting critic targets
    td = TensorDict(
        {
            "observation": torch.randn(20, OBS),
            "task_id": ids,
            "advantage": torch.randn(20, 1),
            "value_target": 3.0 * sign + torch.randn(20, 1),
        },
        [20],
    )
    module = make_gradient_method(method, loss, 3, diagnostics_every=1)
    monkeypatch.setattr(tw, "check_task_ids", lambda *a, **k: None)  # the CPU-only id check

    forbid_host_sync(monkeypatch)
    for _ in range(2):
        metrics = module.backward(td)
    monkeypatch.undo()
    assert all(torch.isfinite(p.grad).all() for p in loss.parameters())
    assert torch.isfinite(metrics["grad_cos_critic_mean"])


def _mt_ppo_minibatch(k: int = 3, state: int = 5, n: int = 48):
    from mtbench.objectives import MTPPOLoss
    from mtbench.trainer.actor_critic import make_actor, make_critic

    arch = {"name": "mlp", "kwargs": {"hidden": [16, 16]}}
    torch.manual_seed(0)
    actor = make_actor(arch, obs_dim=state + k, action_dim=2, num_tasks=k)
    critic = make_critic(arch, obs_dim=state + k, num_tasks=k)
    loss = MTPPOLoss(actor, critic, num_tasks=k)
    ids = torch.arange(n) % k
    ids[ids == 1] = 0  # task 1 absent: the masks, not the shapes, change
    obs = torch.cat([torch.randn(n, state), torch.nn.functional.one_hot(ids, k).float()], -1)
    td = TensorDict({"observation": obs, "task_id": ids}, [n])
    with torch.no_grad():
        actor(td)
    td["advantage"] = torch.randn(n, 1)
    td["value_target"] = torch.randn(n, 1) + 3.0 * (ids[:, None] == 2)
    td["state_value"] = td["value_target"] + 0.05 * torch.randn(n, 1)
    return loss, td


@pytest.mark.parametrize("method", ["none", "pcgrad", "cagrad", "famo"])
def test_graphed_minibatch_step_has_no_host_sync(monkeypatch, method):
    """The whole step the CUDA-graphed update captures -- MTPPOLoss, the method's backward, grad-norm clip, fused
    Adam with a tensor lr -- converts no tensor to Python and uses no data-dependent shape (nonzero, boolean-mask
    indexing), on the CPU with the conversions patched to raise. (C++-internal CPU checks are not seen: e.g. the
    CPU ``lu_solve`` behind CAGrad's ``linalg.solve_ex`` checks its pivots with two ``item()`` -- CPU only;
    benchmarks/update_check.py captures the step on a GPU.)"""
    import mtbench.objectives.task_wrapper as tw
    from mtbench.trainer.builder import graph_safe_update
    from mtbench.trainer.update import MinibatchUpdate

    loss, td = _mt_ppo_minibatch()
    module = make_gradient_method(method, loss, 3)
    assert graph_safe_update(module, loss)
    params = [p for p in loss.parameters() if p.requires_grad]
    opt = torch.optim.Adam(params, lr=torch.tensor(1e-3), fused=True, capturable=False)
    update = MinibatchUpdate(module, opt, max_grad_norm=1.0, call_hooks=lambda *a: None)
    update.step(td)  # first call: lazy set-up (term discovery, optimizer state) happens before capture
    monkeypatch.setattr(tw, "check_task_ids", lambda *a, **k: None)  # CPU-only id check (skipped on CUDA)

    forbid_host_sync(monkeypatch)
    before = [p.detach().clone() for p in params]
    for _ in range(2):
        metrics = update.step(td)
    monkeypatch.undo()
    assert all(torch.isfinite(p).all() for p in params)
    assert any(not torch.equal(a, b) for a, b in zip(before, params, strict=True))
    assert torch.isfinite(metrics["grad_norm"])


def test_graph_update_resolution_for_gradient_methods():
    from mtbench.trainer.builder import graph_safe_update, resolve_graph_update

    cuda, cpu = torch.device("cuda"), torch.device("cpu")
    loss, _ = _mt_ppo_minibatch()
    for name in ("pcgrad", "cagrad", "famo"):
        for every in (0, 5):  # diagnostics are scheduled between graph replays: graph-safe either way
            module = make_gradient_method(name, loss, 3, diagnostics_every=every)
            assert module.cuda_graph_safe and graph_safe_update(module, loss)
            assert resolve_graph_update("auto", cuda, graph_safe_update(module, loss))
            assert resolve_graph_update(True, cuda, graph_safe_update(module, loss))
            assert not resolve_graph_update("auto", cpu, graph_safe_update(module, loss))
            assert not resolve_graph_update(False, cuda, graph_safe_update(module, loss))
    diagnostics = make_gradient_method("none", loss, 3, diagnostics_every=1)
    assert diagnostics is not loss and graph_safe_update(diagnostics, loss)
    plain = make_gradient_method("none", loss, 3)
    assert plain is loss and graph_safe_update(plain, loss)
    assert resolve_graph_update("auto", cuda, True)
    assert not resolve_graph_update("auto", cuda, False)  # a user's wrapper that does not declare itself safe
    with pytest.raises(ValueError, match="graph-safe"):
        resolve_graph_update(True, cuda, False)
    with pytest.raises(ValueError, match="CUDA"):
        resolve_graph_update(True, cpu, True)


@pytest.mark.parametrize("method", ["none", "pcgrad", "cagrad", "famo"])
def test_diagnostics_scheduled_by_the_caller_equal_those_of_backward(method):
    """The protocol of the CUDA-graphed update (``diagnostics_in_backward = False``; before each update
    ``measure_diagnostics`` when ``diagnostics_due()``, then ``count_update()``) gives the same gradients and the
    same reported diagnostics at every update as the backward's own schedule, and refreshes the reported tensors
    in place (a captured graph reads them at fixed addresses)."""
    loss_a, td = _mt_ppo_minibatch()
    loss_b = copy.deepcopy(loss_a)
    a = make_gradient_method(method, loss_a, 3, diagnostics_every=2, **({"seed": 1} if method == "pcgrad" else {}))
    b = make_gradient_method(method, loss_b, 3, diagnostics_every=2, **({"seed": 1} if method == "pcgrad" else {}))
    b.diagnostics_in_backward = False
    params_a = [p for p in loss_a.parameters() if p.requires_grad]
    params_b = [p for p in loss_b.parameters() if p.requires_grad]
    opt_a, opt_b = torch.optim.SGD(params_a, lr=0.05), torch.optim.SGD(params_b, lr=0.05)
    held = None
    for step in range(5):
        batch = td[torch.randperm(td.shape[0], generator=torch.Generator().manual_seed(step))]
        for p in (*params_a, *params_b):
            p.grad = None
        out_a = a.backward(batch)
        if b.diagnostics_due():
            b.measure_diagnostics(batch)
        b.count_update()
        out_b = b.backward(batch)
        assert a.num_updates == b.num_updates == step + 1
        for key in DIAGNOSTIC_KEYS:
            torch.testing.assert_close(out_b[key], out_a[key], equal_nan=True)
        for pa, pb in zip(params_a, params_b, strict=True):
            torch.testing.assert_close(pb.grad, pa.grad)
        if held is None:
            held = {k: b._last_diagnostics[k] for k in DIAGNOSTIC_KEYS if k in b._last_diagnostics}
            assert held
        assert all(b._last_diagnostics[k] is v for k, v in held.items())  # refreshed in place
        opt_a.step()
        opt_b.step()
    assert torch.isfinite(held["grad_cos_critic_mean"]) and -1.0 <= float(held["grad_cos_critic_mean"]) <= 1.0


@pytest.mark.parametrize("method", ["none", "pcgrad", "famo"])
def test_graphed_update_path_schedules_diagnostics_like_the_eager_one(method):
    """``MinibatchUpdate(graph=True)`` (its code path runs on a CPU: static buffers, the step called directly)
    measures the diagnostics between updates and counts them itself; from the same state and permutation it gives
    exactly the parameters, update counter and mean metrics (``grad_cos_*`` included) of the eager updater."""
    from mtbench.trainer.update import MinibatchUpdate

    loss, td = _mt_ppo_minibatch()
    results = []
    for graph in (False, True):
        module = make_gradient_method(method, copy.deepcopy(loss), 3, diagnostics_every=3,
                                      **({"seed": 1} if method == "pcgrad" else {}))
        params = [p for p in module.loss_module.parameters() if p.requires_grad]
        opt = torch.optim.Adam(params, lr=1e-3)
        update = MinibatchUpdate(module, opt, max_grad_norm=1.0, call_hooks=lambda *a: None, graph=graph)
        assert module.diagnostics_in_backward is not graph
        torch.manual_seed(0)  # the minibatch permutation
        means, count = update.epochs(td, 2, td.shape[0] // 4)
        results.append((means, count, module.num_updates, [p.detach().clone() for p in params]))
    (m_e, c_e, n_e, p_e), (m_g, c_g, n_g, p_g) = results
    assert c_e == c_g == 8 and n_e == n_g == 8
    assert set(DIAGNOSTIC_KEYS) <= m_e.keys() and m_e.keys() == m_g.keys()
    for key in m_e:
        torch.testing.assert_close(m_g[key], m_e[key], rtol=0, atol=0, equal_nan=True)
    for a, b in zip(p_e, p_g, strict=True):
        assert torch.equal(a, b)


def test_pcgrad_generator_for_graph_capture_and_checkpoints():
    """PCGrad exposes its order generator (registered with a captured graph) once created, and re-creates it when
    a checkpoint is loaded, so that a re-capture (without eager warm-up) can register it; orders continue exactly."""
    loss, td = _mt_ppo_minibatch()
    module = make_gradient_method("pcgrad", loss, 3, seed=3)
    assert module.cuda_graph_generators() == []
    module.backward(td)
    (gen,) = module.cuda_graph_generators()
    state = {k: v for k, v in module.state_dict().items()}
    expected = torch.rand(4, generator=gen)
    other = make_gradient_method("pcgrad", loss, 3, seed=0)
    other.load_state_dict(state)
    (gen2,) = other.cuda_graph_generators()
    assert gen2 is not gen and torch.equal(torch.rand(4, generator=gen2), expected)
