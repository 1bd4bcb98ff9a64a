"""MT-SAC: n-step transitions (known answers: early done, truncation bootstrap, termination, carry across rollouts),
per-task temperatures (gradients, per-sample use), equality with TorchRL's SACLoss, keys, the on-device replay buffer
and its checkpoint, exact resume of the off-policy loop, config errors, and the loss=sac front door.

Known answers: /work/shared/reference/mtrl-algorithms.md section 2.3 (MT-SAC).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
import torch
from hydra import compose, initialize_config_dir
from tensordict import TensorDict
from torchrl.objectives import SACLoss, SoftUpdate
from torchrl.objectives.utils import ValueEstimators

from cpu_runs import assert_same_metrics, compose_config, one_torch_thread
from envs_for_tests import SyntheticMTEnv
from host_sync import forbid_host_sync
from mtbench.objectives import MTSACLoss, NStepTransitions, nstep_transitions
from mtbench.trainer import NonFiniteGuard, OffPolicyTrainer, build_trainer, make_qvalue, make_sac_actor
from mtbench.trainer.hooks import TrainerHook
from mtbench.trainer.checkpoint import load_checkpoint
from mtbench.trainer.replay import load_replay_state_dict, make_replay_buffer, replay_state_dict
from mtbench.trainer.sac_builder import build_sac_optimizer, check_sac_features
from mtbench.trainer.update import MinibatchUpdate

CONF = str(Path(__file__).resolve().parents[1] / "conf")
K, STATE, ACT = 3, 5, 2
ARCH = {"name": "mlp", "kwargs": {"hidden": [16, 16], "activation": "relu"}}


# ---------------------------------------------------------------------------------------------- helpers
@pytest.fixture(autouse=True)
def _one_thread():
    """Small networks: one intra-op thread is much faster on a busy 2-core machine (restored afterwards)."""
    with one_torch_thread():
        yield


def _steps(rewards, dones, terminated, gamma_obs_offset: float = 0.0) -> TensorDict:
    """A hand-made [N, L] rollout: scalar observations o_t = t (+ 100 * env), next observation o_{t+1} except NaN
    on done rows (native autoreset), task id = env index."""
    r = torch.tensor(rewards, dtype=torch.float32)
    n, length = r.shape
    obs = torch.arange(length, dtype=torch.float32).expand(n, length) + 100.0 * torch.arange(n)[:, None]
    done = torch.tensor(dones, dtype=torch.bool)
    nxt = torch.where(done, torch.full_like(obs, float("nan")), obs + 1)
    return TensorDict(
        {
            "observation": obs[..., None],
            "action": obs[..., None] * 10,
            "task_id": torch.arange(n)[:, None].expand(n, length).clone(),
            "next": {
                "observation": nxt[..., None],
                "reward": r[..., None],
                "done": done[..., None],
                "terminated": torch.tensor(terminated, dtype=torch.bool)[..., None],
            },
        },
        batch_size=[n, length],
    )


def _networks(seed: int = 0):
    torch.manual_seed(seed)
    actor = make_sac_actor(ARCH, obs_dim=STATE + K, action_dim=ACT, num_tasks=K)
    qvalues = [make_qvalue(ARCH, obs_dim=STATE + K, action_dim=ACT, num_tasks=K) for _ in range(2)]
    return actor, qvalues


def _batch(n: int = 24, seed: int = 1, num_tasks: int = K) -> TensorDict:
    g = torch.Generator().manual_seed(seed)
    ids = torch.arange(n) % num_tasks
    one_hot = torch.nn.functional.one_hot(ids, num_tasks).float()
    term = torch.rand(n, 1, generator=g) < 0.25
    return TensorDict(
        {
            "observation": torch.cat([torch.randn(n, STATE, generator=g), one_hot], -1),
            "action": torch.rand(n, ACT, generator=g) * 2 - 1,
            "task_id": ids,
            "steps_to_next_obs": torch.randint(1, 4, (n, 1), generator=g),
            "next": {
                "observation": torch.cat([torch.randn(n, STATE, generator=g), one_hot], -1),
                "task_id": ids,
                "reward": torch.randn(n, 1, generator=g) + 3.0 * (ids[:, None] % 2),
                "done": term.clone(),
                "terminated": term,
            },
        },
        batch_size=[n],
    )


def _cfg(tmp_path: Path, *overrides: str):
    other_arch = any(o.startswith("arch=") for o in overrides)
    base = [
        "device=cpu",
        "loss=sac",
        *([] if other_arch else ["arch.kwargs.hidden=[32,32]"]),
        "loss.batch_size=32",
        "loss.replay_buffer_size=100",
        "loss.gradient_steps_per_iteration=2",
        "max_iterations=12",
        f"checkpoint.dir={tmp_path / 'ckpt'}",
        "checkpoint.every=0",
        "logging.progress=none",
        f"logging.log_dir={tmp_path / 'runs'}",
    ]
    return compose_config([*base, *overrides])


def _env(**kwargs: Any) -> SyntheticMTEnv:
    return SyntheticMTEnv([4, 4, 4], max_episode_steps=6, seed=0, **kwargs)


# ---------------------------------------------------------------------------------------------- n-step returns
def test_nstep_known_answers_early_done_truncation_bootstrap_and_termination():
    # env 0: truncation at step 1; env 1: termination at step 3; gamma 0.5, n = 3
    steps = _steps(rewards=[[1, 2, 3, 4, 5], [1, 1, 1, 1, 1]],
                   dones=[[0, 1, 0, 0, 0], [0, 0, 0, 1, 0]],
                   terminated=[[0, 0, 0, 0, 0], [0, 0, 0, 1, 0]])
    out = nstep_transitions(steps, 3, 0.5)
    assert out.batch_size == (2, 3)
    # start 0 of env 0: the window stops at the truncation (step 1): 1 + 0.5 * 2, bootstrap gamma^2 V(o_1)
    # start 1: stops at once: 2, bootstrap gamma V(o_1); start 2: full window 3 + 0.5 * 4 + 0.25 * 5 -> o_5
    assert out["next", "reward"][0].squeeze(-1).tolist() == [2.0, 2.0, 6.25]
    assert out["steps_to_next_obs"][0].squeeze(-1).tolist() == [2, 1, 3]
    assert out["next", "observation"][0].squeeze(-1).tolist() == [1.0, 1.0, 5.0]  # o_1 stands in for the lost final
    assert out["next", "done"][0].squeeze(-1).tolist() == [True, True, False]
    assert out["next", "terminated"][0].squeeze(-1).tolist() == [False, False, False]  # truncation: bootstrap
    # env 1: the termination at step 3 ends the windows of starts 1 and 2; no bootstrap there
    assert out["next", "reward"][1].squeeze(-1).tolist() == [1.75, 1.75, 1.5]
    assert out["steps_to_next_obs"][1].squeeze(-1).tolist() == [3, 3, 2]
    assert out["next", "terminated"][1].squeeze(-1).tolist() == [False, True, True]
    assert out["next", "observation"][1].squeeze(-1).tolist() == [103.0, 103.0, 103.0]
    assert torch.isfinite(out["next", "observation"]).all()  # the NaN rows never reach a transition
    # first-step entries come from the start of the window
    assert out["observation"][0].squeeze(-1).tolist() == [0.0, 1.0, 2.0]
    assert out["action"][1].squeeze(-1).tolist() == [1000.0, 1010.0, 1020.0]
    assert torch.equal(out["next", "task_id"], out["task_id"])
    assert nstep_transitions(steps[:, :2], 3, 0.5) is None  # no complete window


def test_nstep_value_target_discounts_by_gamma_to_the_k():
    """TD(0) target of MT-SAC's estimator on n-step transitions: R + gamma^k (1 - terminated) V(s')."""
    actor, qvalues = _networks()
    loss = MTSACLoss(actor, qvalues, num_tasks=K, gamma=0.9)
    td = _batch(12)
    value = torch.randn(12, 1)
    td["next", "state_value"] = value
    got = loss.value_estimator.value_estimate(td.clone())
    k = td["steps_to_next_obs"].float()
    not_term = (~td["next", "terminated"]).float()
    assert torch.allclose(got, td["next", "reward"] + 0.9 ** k * not_term * value)
    loss.set_keys(steps_to_next_obs="k")  # renamed: the estimator follows
    td.rename_key_("steps_to_next_obs", "k")
    assert torch.allclose(loss.value_estimator.value_estimate(td.clone()), got)


def test_nstep_carry_across_rollouts_equals_one_long_rollout():
    g = torch.Generator().manual_seed(0)
    length = 9
    rewards = torch.randn(3, length, generator=g).tolist()
    dones = (torch.rand(3, length, generator=g) < 0.2).long().tolist()
    steps = _steps(rewards, dones, [[0] * length] * 3)
    whole = nstep_transitions(steps, 4, 0.9)  # [3, 6]
    stream = NStepTransitions(4, 0.9)
    chunks = []
    for t in range(length):  # horizon 1, as MTBench
        out = stream(steps[:, t : t + 1].clone())
        assert (out is None) == (t < 3) and stream.carried_steps == min(t + 1, 3)
        if out is not None:
            chunks.append(out)
    streamed = torch.stack(chunks, dim=1)  # [3, 6]
    assert (streamed == whole).all()
    restored = NStepTransitions(4, 0.9)
    restored.load_state_dict(stream.state_dict())
    with pytest.raises(ValueError, match="loss.nstep=3"):
        NStepTransitions(3, 0.9).load_state_dict(stream.state_dict())
    with pytest.raises(ValueError, match="loss.nstep must be an integer >= 1"):
        NStepTransitions(0, 0.9)


# ---------------------------------------------------------------------------------------------- the loss
def test_per_task_alpha_gradient_depends_only_on_its_tasks_samples():
    actor, qvalues = _networks()
    loss = MTSACLoss(actor, qvalues, num_tasks=K, reduction="none", target_entropy=-2.0)
    with torch.no_grad():
        loss.log_alpha.copy_(torch.log(torch.tensor([0.5, 1.0, 2.0])))
    td = _batch(24)

    def alpha_grad(batch):
        loss.log_alpha.grad = None
        torch.manual_seed(3)
        out = loss(batch.clone())
        out["loss_alpha"].mean().backward()
        return loss.log_alpha.grad.clone(), out["loss_alpha"].detach()

    grad, per_sample = alpha_grad(td)
    ids = td["task_id"]
    # d/dlog(alpha_k) mean_i alpha_t(i) (-log pi_i - H) = sum_{i in k} loss_alpha_i / N
    expected = torch.stack([per_sample[ids == k].sum() for k in range(K)]) / 24
    assert torch.allclose(grad, expected, atol=1e-6)
    assert torch.all(grad != 0)
    perturbed = td.clone()
    perturbed["observation"][ids == 1, :STATE] += 3.0  # change task 1's samples only
    grad2, _ = alpha_grad(perturbed)
    assert grad2[0] == grad[0] and grad2[2] == grad[2] and grad2[1] != grad[1]


def test_each_sample_uses_its_tasks_temperature_in_target_and_actor_loss():
    actor, qvalues = _networks()
    per_task = MTSACLoss(actor, qvalues, num_tasks=K, reduction="none", target_entropy=-2.0)
    alphas = torch.tensor([0.1, 1.0, 5.0])
    with torch.no_grad():
        per_task.log_alpha.copy_(alphas.log())
    td = _batch(24)
    torch.manual_seed(0)
    out = per_task(td.clone())
    assert torch.allclose(out["alpha"], alphas[td["task_id"]].mean())
    for k in range(K):  # a shared temperature equal to task k's gives task k's samples the same losses
        shared = MTSACLoss(actor, qvalues, num_tasks=K, reduction="none", target_entropy=-2.0, per_task_alpha=False,
                           alpha_init=float(alphas[k]))
        shared.load_state_dict({n: v for n, v in per_task.state_dict().items() if "log_alpha" not in n}, strict=False)
        torch.manual_seed(0)
        ref = shared(td.clone())
        mask = td["task_id"] == k
        for name in ("loss_actor", "loss_qvalue", "loss_alpha"):
            assert torch.allclose(out[name][mask], ref[name][mask], atol=1e-5), (k, name)
        assert not torch.allclose(out["loss_qvalue"][~mask], ref["loss_qvalue"][~mask], atol=1e-5)


@pytest.mark.parametrize("reduction", ["mean", "none"])
def test_one_task_equals_torchrl_sac_loss(reduction):
    """With one task, TorchRL's temperature loss and the same Q loss, MTSACLoss is SACLoss: terms and gradients."""
    torch.manual_seed(0)
    arch = {"name": "mlp", "kwargs": {"hidden": [16, 16]}}
    actor = make_sac_actor(arch, obs_dim=STATE + 1, action_dim=ACT, num_tasks=1)
    qvalues = [make_qvalue(arch, obs_dim=STATE + 1, action_dim=ACT, num_tasks=1) for _ in range(2)]
    kwargs = dict(loss_function="l2", target_entropy=-float(ACT), alpha_init=0.7, reduction=reduction)
    stock = SACLoss(actor, qvalues, scalar_output_mode="exclude", **kwargs)
    stock.make_value_estimator(ValueEstimators.TD0, gamma=0.95)
    ours = MTSACLoss(actor, qvalues, num_tasks=1, alpha_loss="log_alpha", gamma=0.95, **kwargs)
    assert torch.equal(ours.qvalue_network_params["module", "net", "head", "weight"],
                       stock.qvalue_network_params["module", "net", "head", "weight"])
    td = _batch(16, num_tasks=1)
    results = []
    for loss in (stock, ours):
        for p in loss.parameters():
            p.grad = None
        torch.manual_seed(7)
        out = loss(td.clone())
        total = sum(out[k].sum() for k in ("loss_actor", "loss_qvalue", "loss_alpha"))
        total.backward()
        grads = [p.grad.clone() for p in (*loss.actor_network_params.values(True, True),
                                          *loss.qvalue_network_params.values(True, True))]
        results.append((out, grads, loss.log_alpha.grad.reshape(())))
    (a, ga, la), (b, gb, lb) = results
    for name in ("loss_actor", "loss_qvalue", "loss_alpha"):
        assert a[name].shape == b[name].shape and torch.allclose(a[name], b[name], atol=1e-6), name
    assert all(torch.allclose(x, y, atol=1e-6) for x, y in zip(ga, gb))
    assert torch.allclose(la, lb, atol=1e-6)
    if reduction == "mean":
        assert torch.allclose(a["alpha"], b["alpha"]) and torch.allclose(a["entropy"], b["entropy"])


def test_mtbench_alpha_loss_and_keys():
    actor, qvalues = _networks()
    loss = MTSACLoss(actor, qvalues, num_tasks=K, reduction="none", target_entropy=-2.0, alpha_init=0.5)
    td = _batch(12)
    torch.manual_seed(0)
    out = loss(td.clone())
    log_prob = -out["entropy"]  # batch mean of log pi
    # alpha (-log pi - H) with alpha = 0.5 for every task: its batch mean is 0.5 * (-mean log pi + 2)
    assert torch.allclose(out["loss_alpha"].mean(), 0.5 * (-log_prob + 2.0), atol=1e-6)
    assert set(loss.in_keys) >= {"task_id", "action", ("next", "reward"), ("next", "terminated"), ("next", "task_id")}
    # every key renames through set_keys; the temperature is chosen by the renamed task key
    renamed = MTSACLoss(actor, qvalues, num_tasks=K, reduction="none", target_entropy=-2.0)
    with torch.no_grad():
        renamed.log_alpha.copy_(torch.log(torch.tensor([0.1, 1.0, 5.0])))
    renamed.set_keys(task_id="tid", reward="r", terminated="term", done="d")
    batch = td.clone()
    batch["tid"] = torch.full((12,), 2)  # the network inputs keep "task_id"; the temperature follows "tid"
    batch.rename_key_(("next", "reward"), ("next", "r"))
    batch.rename_key_(("next", "terminated"), ("next", "term"))
    batch.rename_key_(("next", "done"), ("next", "d"))
    torch.manual_seed(0)
    got = renamed(batch)
    assert torch.allclose(got["alpha"], torch.tensor(5.0))
    assert "tid" in renamed.in_keys and ("next", "r") in renamed.in_keys
    with pytest.raises(KeyError, match="task index 'tid'"):
        renamed(td.clone())
    with pytest.raises(ValueError, match="valid choices: \\['alpha', 'log_alpha'\\]"):
        MTSACLoss(actor, qvalues, num_tasks=K, alpha_loss="alpha2")


def test_fixed_temperature_and_soft_update():
    actor, qvalues = _networks()
    loss = MTSACLoss(actor, qvalues, num_tasks=K, fixed_alpha=True, alpha_init=0.2, target_entropy=-2.0)
    assert not isinstance(loss.log_alpha, torch.nn.Parameter) and loss.log_alpha.shape == (K,)
    assert torch.allclose(loss.alphas, torch.full((K,), 0.2))
    updater = SoftUpdate(loss, tau=0.25)
    source = loss.qvalue_network_params["module", "net", "head", "weight"]
    target = loss.target_qvalue_network_params["module", "net", "head", "weight"]
    assert torch.equal(source, target)
    with torch.no_grad():
        source.add_(1.0)
    before = target.clone()
    updater.step()
    assert torch.allclose(target, 0.75 * before + 0.25 * source)


# ---------------------------------------------------------------------------------------------- replay buffer
def test_replay_buffer_on_env_device_and_compact_exact_state():
    buffer = make_replay_buffer(10, 4, "cpu")
    for start in (0, 7):
        buffer.extend(TensorDict({"x": torch.arange(start, start + 7.0)}, [7]))  # wraps around
    state = replay_state_dict(buffer)
    assert state["size"] == 10 and state["writer"]["_cursor"] == 4 and state["data"].batch_size == (10,)
    restored = make_replay_buffer(10, 4, "cpu")
    load_replay_state_dict(restored, state, "cpu")
    assert torch.equal(restored.storage[:10]["x"], buffer.storage[:10]["x"])
    torch.manual_seed(0)
    a = buffer.sample()["x"]
    torch.manual_seed(0)
    assert torch.equal(restored.sample()["x"], a)  # same uniform draws
    for b in (buffer, restored):
        b.extend(TensorDict({"x": torch.tensor([-1.0])}, [1]))
    assert torch.equal(restored.storage[:10]["x"], buffer.storage[:10]["x"])  # same write position
    with pytest.raises(ValueError, match="loss.replay_buffer_size is 20"):
        load_replay_state_dict(make_replay_buffer(20, 4, "cpu"), state, "cpu")
    with pytest.raises(ValueError, match=r"loss.batch_size must be an integer in \[1, loss.replay_buffer_size = 10\]"):
        make_replay_buffer(10, 11, "cpu")


def test_off_policy_loop_fills_the_buffer_on_the_env_device(tmp_path: Path):
    trainer = build_trainer(_cfg(tmp_path, "max_iterations=6"), env=_env())
    assert isinstance(trainer, OffPolicyTrainer)
    assert trainer.warmup_iterations == 4 and trainer.nstep.n == 4
    history = trainer.train()
    # 12 worlds: the first window completes after 4 env steps, then 12 transitions per step
    assert [h["train/replay_size"] for h in history] == [0, 0, 0, 12, 24, 36]
    assert trainer.updates == 2 * 2  # the warm-up (4 iterations) updates nothing
    assert "loss/qvalue" not in history[3] and "loss/qvalue" in history[4]
    assert {f"alpha/task{k}" for k in range(K)} <= set(history[-1])
    assert history[-1]["train/lr_critic"] == pytest.approx(5e-4) and history[-1]["train/lr_alpha"] == pytest.approx(5e-3)
    stored = trainer.replay.storage[:36]
    assert stored.device == trainer.env.device
    # raw observations in the buffer (the env transform normalises what the policy sees)
    assert torch.allclose(stored["observation"][:, -K:].sum(-1), torch.ones(36))
    assert stored["observation"][:, :STATE].abs().max() <= 2.0 + 1e-6  # SyntheticMTEnv's raw range
    assert torch.isfinite(stored["next", "observation"]).all()
    assert trainer.get_hook(NonFiniteGuard).streak == 0


def test_resume_is_exact_with_the_replay_buffer_and_without_it(tmp_path: Path):
    full = build_trainer(_cfg(tmp_path, "checkpoint.every=6"), env=_env())
    full_history = full.train()
    ckpt = tmp_path / "ckpt" / "ckpt_000006.pt"
    saved = load_checkpoint(ckpt)
    assert saved["replay"]["size"] == 36 and saved["nstep"]["carry"].batch_size == (12, 3)
    action = saved["replay"]["data"]["action"]  # only the filled rows are saved, not the buffer's capacity (100)
    assert action.shape == (36, ACT) and action.untyped_storage().nbytes() == 36 * ACT * action.element_size()
    resumed = build_trainer(_cfg(tmp_path, f"resume={ckpt}", f"checkpoint.dir={tmp_path / 'b'}"), env=_env())
    assert len(resumed.replay) == 36 and resumed.iteration == 6
    rest = resumed.train()
    assert len(rest) == 6
    for a, b in zip(full_history[6:], rest):  # the buffer wraps around (capacity 100) after iteration 11
        assert_same_metrics(a, b)
    for (name, a), (_, b) in zip(full.loss.state_dict().items(), resumed.loss.state_dict().items()):
        assert torch.equal(a, b), name
    assert torch.equal(full.replay.storage[:100]["action"], resumed.replay.storage[:100]["action"])

    small = build_trainer(_cfg(tmp_path, "loss.replay_in_checkpoint=false", "checkpoint.every=6",
                               f"checkpoint.dir={tmp_path / 'c'}"), env=_env())
    small.train()
    ckpt_small = tmp_path / "c" / "ckpt_000006.pt"
    assert load_checkpoint(ckpt_small)["replay"] is None and ckpt_small.stat().st_size < ckpt.stat().st_size
    again = build_trainer(_cfg(tmp_path, "loss.replay_in_checkpoint=false", f"resume={ckpt_small}",
                               f"checkpoint.dir={tmp_path / 'd'}"), env=_env())
    assert len(again.replay) == 0
    history = again.train()  # refills from the carried steps on: 12 transitions per iteration
    assert [h["train/replay_size"] for h in history][:2] == [12, 24] and again.iteration == 12


# ---------------------------------------------------------------------------------------------- CUDA-graphed update
#: buffer of 36 transitions: warm-up iterations 0-3 (12 transitions at 3), eager updates at 4 (24), full from 5 on
GRAPH_RUN = ("loss.replay_buffer_size=36", "loss.overlap_update=false")  # sequential: the eager order


def _graphed(trainer: OffPolicyTrainer) -> OffPolicyTrainer:
    """``trainer`` with what ``cudagraph_update=true`` builds on a GPU: a ``capturable=True`` optimizer and
    ``MinibatchUpdate(graph=True)`` (on the CPU its code path runs eagerly: nothing is captured)."""
    eager = trainer.updater
    trainer.optimizer = build_sac_optimizer(trainer.loss, trainer.config.loss, torch.device("cpu"), capturable=True)
    trainer.updater = MinibatchUpdate(trainer.update_module, trainer.optimizer, max_grad_norm=eager.max_grad_norm,
                                      clip_groups=eager.clip_groups, call_hooks=trainer._call,
                                      after_step=eager.after_step, graph=True, device="cpu")
    assert trainer.updater.graph and not trainer.updater._drawn_stage.enabled
    return trainer


def _counting_draws(trainer: OffPolicyTrainer) -> list[int]:
    calls: list[int] = []
    draw = trainer.draw_from_full_replay

    def counted() -> TensorDict:
        calls.append(trainer.iteration)
        return draw()

    trainer._draw = counted
    return calls


@pytest.mark.parametrize("grad", ["none", "pcgrad"])
def test_graphed_sac_update_has_no_host_sync(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, grad: str):
    """The whole update the CUDA graph captures for ``loss=sac`` once the buffer is full -- indices drawn on the
    device, rows gathered into the static buffers, observations normalised with the current per-task statistics,
    ``MTSACLoss`` (twin Q, actor, per-task temperatures; or PCGrad's backward), the three clip groups, the
    non-finite guard's ``found_inf``, the ``capturable=True`` fused Adam step, the soft target update -- converts
    no tensor to Python and uses no data-dependent shape, on the CPU with the conversions patched to raise."""
    import mtbench.objectives.task_wrapper as tw

    trainer = _graphed(build_trainer(_cfg(tmp_path, *GRAPH_RUN, f"grad={grad}", "max_iterations=6"), env=_env()))
    trainer.train()
    assert trainer.replay_full() and trainer.updates == 2 * 2
    monkeypatch.setattr(tw, "check_task_ids", lambda *a, **k: None)  # CPU-only id check (skipped on CUDA)
    loss = trainer.loss

    def state() -> list[torch.Tensor]:
        return [t.detach().clone() for t in loss.state_dict().values()] + [
            t.clone() for s in trainer.optimizer.state.values() for t in s.values()]

    calls = _counting_draws(trainer)
    before = state()
    forbid_host_sync(monkeypatch)
    means = trainer.update(3)
    after = state()
    monkeypatch.undo()
    assert len(calls) == 3 and torch.isfinite(means["loss_qvalue"]) and float(means["skipped"]) == 0.0
    assert {"loss_actor", "loss_qvalue", "loss_alpha", "grad_norm_actor", "grad_norm_critic",
            "grad_norm_alpha"} <= set(means)
    n = len(loss.state_dict())
    moved = {k for k, a, b in zip(loss.state_dict(), before[:n], after[:n], strict=True) if not torch.equal(a, b)}
    assert "log_alpha" in moved and any(k.startswith("target_qvalue_network_params") for k in moved)
    assert any(k.startswith("actor_network_params") for k in moved)
    assert not all(torch.equal(a, b) for a, b in zip(before[n:], after[n:], strict=True))  # Adam's moments


@pytest.mark.parametrize("grad", [(), ("grad=pcgrad", "grad.diagnostics_every=3")])
def test_graphed_sac_update_path_equals_the_eager_one(tmp_path: Path, grad: tuple[str, ...]):
    """From the same seed, 9 iterations with the graphed code path (eager updates while the buffer fills, the
    draw-and-update of the graph once it is full, from iteration 5 on; run eagerly on the CPU) give exactly the
    metrics, parameters, temperatures, target networks and optimizer state of the eager path (replay samples of
    TorchRL's sampler; an optimizer without ``capturable``). With PCGrad and diagnostics every 3 updates: due
    updates run eagerly between the replays. (benchmarks/update_check.py --loss sac compares the replayed CUDA
    graph with the eager update on a GPU.)"""
    runs = []
    for graph in (False, True):
        trainer = build_trainer(_cfg(tmp_path, *GRAPH_RUN, *grad, "max_iterations=9"), env=_env())
        if graph:
            trainer = _graphed(trainer)
        calls = _counting_draws(trainer)
        runs.append((trainer, trainer.train(), calls))
    (eager, eager_history, eager_calls), (graphed, graphed_history, graphed_calls) = runs
    assert eager_calls == [] and graphed_calls == [5, 5, 6, 6, 7, 7, 8, 8]  # the switch at the first full buffer
    assert [h["train/replay_size"] for h in graphed_history] == [0, 0, 0, 12, 24, 36, 36, 36, 36]
    for a, b in zip(eager_history, graphed_history, strict=True):
        assert_same_metrics(a, b)
    assert "alpha/task0" in graphed_history[-1] and "loss/qvalue" in graphed_history[-1]
    if grad:
        assert "train/grad_cos_critic_mean" in graphed_history[-1]
    for (key, a), (_, b) in zip(eager.loss.state_dict().items(), graphed.loss.state_dict().items(), strict=True):
        assert torch.equal(a, b), key  # parameters, target Q networks, log_alpha
    eager_state, graphed_state = eager.optimizer.state_dict()["state"], graphed.optimizer.state_dict()["state"]
    assert eager_state.keys() == graphed_state.keys()
    for index, saved in eager_state.items():
        for key, value in saved.items():
            assert torch.equal(graphed_state[index][key], value), (index, key)
    assert eager.updates == graphed.updates == 2 * 5


def test_overlapped_updates_run_before_the_collection_and_it_acts_with_the_pre_update_actor(tmp_path: Path):
    """``loss.overlap_update``: once the graphed update runs (CPU: its code path; iteration 5 draws the first batch
    from the full buffer), each iteration launches its updates first, on the buffer of the previous iterations
    (on a GPU on a side stream, concurrently with the env), then collects with a copy of the actor taken before
    those updates, then stores the new transitions; before that (warm-up, filling buffer, first graphed
    iteration) the order is the sequential one. The trained actor is not the acting one."""
    trainer = _graphed(build_trainer(_cfg(tmp_path, *GRAPH_RUN, "loss.overlap_update=true", "max_iterations=9"),
                                     env=_env()))
    assert trainer.overlap_update and trainer.policy.actor is not trainer.actor
    events: list[tuple[str, int]] = []
    draw, extend, act = trainer.draw_from_full_replay, trainer.replay.extend, trainer.policy.actor.forward
    start: dict[str, torch.Tensor] = {}

    def drawn() -> TensorDict:
        events.append(("update", trainer.iteration))
        return draw()

    def extended(data: TensorDict) -> None:
        events.append(("store", trainer.iteration))
        extend(data)

    def acting(td: TensorDict) -> TensorDict:  # the acting copy holds the parameters of the iteration's start
        acting_params = dict(trainer.policy.actor.named_parameters())
        assert all(torch.equal(acting_params[k], v) for k, v in start.items())
        events.append(("act", trainer.iteration))
        return act(td)

    class Start(TrainerHook):
        def on_iteration_start(self, t: OffPolicyTrainer) -> None:
            start.clear()
            start.update({k: v.detach().clone() for k, v in t.actor.named_parameters()})

    trainer._draw, trainer.replay.extend, trainer.policy.actor.forward = drawn, extended, acting
    trainer.add_hook(Start())
    history = trainer.train()
    by_iteration = [[e for e, i in events if i == it] for it in range(9)]
    assert by_iteration[3] == ["store"]  # warm-up: random actions, the actor is not called
    assert by_iteration[4] == ["act", "store"]  # eager updates on TorchRL's sampler (the buffer fills)
    assert by_iteration[5] == ["act", "store", "update", "update"]  # first graphed iteration: sequential
    for it in (6, 7, 8):
        assert by_iteration[it] == ["update", "update", "act", "store"], it
    assert trainer.updates == 2 * 5 and [h["train/replay_size"] for h in history][-1] == 36
    live = dict(trainer.actor.named_parameters())
    assert not all(torch.equal(live[k], v) for k, v in trainer.policy.actor.named_parameters())  # updated since
    # the copy is no autograd edge to the live parameters: on a GPU such an edge (their AccumulateGrad nodes, made
    # on the main stream) broke the capture of the next update on the side stream
    assert all(p.grad_fn is None and not p.requires_grad for p in trainer.policy.actor.parameters())


def test_cudagraph_update_resolves_for_sac():
    """``cudagraph_update`` for ``loss=sac``: ``auto`` and ``true`` on CUDA (graphed once the buffer is full;
    update_check.py --loss sac compared it with the eager update on an H200), clear errors where it is impossible."""
    from mtbench.trainer.builder import graph_safe_update, resolve_graph_update
    from mtbench.objectives import make_gradient_method

    cuda, cpu = torch.device("cuda"), torch.device("cpu")
    actor, qvalues = _networks()
    loss = MTSACLoss(actor, qvalues, num_tasks=K)
    for name in ("none", "pcgrad", "cagrad", "famo"):
        module = make_gradient_method(name, loss, K)
        assert graph_safe_update(module, loss)
        assert resolve_graph_update(True, cuda, graph_safe_update(module, loss))
        assert resolve_graph_update("auto", cuda, graph_safe_update(module, loss))
        assert not resolve_graph_update("auto", cpu, graph_safe_update(module, loss))
        assert not resolve_graph_update(False, cuda, graph_safe_update(module, loss))
    with pytest.raises(ValueError, match=r"cudagraph_update=true needs a CUDA device \(device=cpu\)"):
        resolve_graph_update(True, cpu, True)
    with pytest.raises(ValueError, match="cudagraph_update=true needs a graph-safe update module"):
        resolve_graph_update(True, cuda, False)
    check_sac_features(compose_config(["loss=sac", "cudagraph_update=true"]))  # no longer refused
    cfg = {"actor_lr": 1e-3, "critic_lr": 1e-3, "alpha_lr": 1e-3}
    assert not build_sac_optimizer(loss, cfg, cpu).defaults["capturable"]  # the default optimizer is unchanged
    assert build_sac_optimizer(loss, cfg, cpu, capturable=True).defaults["capturable"]


# ---------------------------------------------------------------------------------------------- config
@pytest.mark.parametrize(
    "override,message",
    [
        ("loss.batch_size=101", "loss.batch_size=101 must not exceed loss.replay_buffer_size=100"),
        ("loss.gradient_steps_per_iteration=0", "loss.gradient_steps_per_iteration must be an integer >= 1; got 0"),
        ("loss.gradient_steps_per_iteration=1.5", "loss.gradient_steps_per_iteration must be an integer >= 1"),
        ("loss.nstep=0", "loss.nstep must be an integer >= 1; got 0"),
        ("loss.warmup_steps=-1", "loss.warmup_steps must be an integer >= 0; got -1"),
        ("loss.gamma=1.5", r"loss.gamma must be a number in \(0.0, 1.0\]; got 1.5"),
        ("loss.critic_lr=0", r"loss.critic_lr must be a number in \(0.0, inf\); got 0"),
        ("loss.critic_tau=2", r"loss.critic_tau must be a number in \(0.0, 1.0\]"),
        ("loss.alpha_loss=exp", r"unknown loss.alpha_loss 'exp'; valid choices: \['alpha', 'log_alpha'\]"),
        ("loss.log_std_bounds=[2,-20]", "loss.log_std_bounds must be \\[min, max\\] with min < max"),
        ("loss.disentangled_alpha=maybe", "loss.disentangled_alpha must be true or false"),
        ("loss.overlap_update=maybe", "loss.overlap_update must be true or false; got 'maybe'"),
        ("+loss.normalize_value=true", "loss.normalize_value=true is not supported by loss=sac"),
        ("cudagraph_update=true", r"cudagraph_update=true needs a CUDA device \(device=cpu\)"),
        ("compile=true", r"compile=true \(torch.compile of the networks\) is not supported with loss=sac"),
    ],
)
def test_config_errors_are_clear(tmp_path: Path, override: str, message: str):
    with pytest.raises(ValueError, match=message):
        build_trainer(_cfg(tmp_path, override), env=_env())


def test_sizing_presets_and_paper_hyperparameters():
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        default = compose("config", overrides=["loss=sac", "env=mt10_rand"])
        mt50 = compose("config", overrides=["loss=sac", "env=mt50_rand"])
        cpu = compose("config", overrides=["loss=sac", "env=cpu_small"])
        paper = compose("config", overrides=["loss=sac", "arch=mlp_sac"])
    lc = default.loss
    assert (lc.batch_size, lc.replay_buffer_size, lc.actor_lr, lc.critic_lr, lc.alpha_lr, lc.init_alpha, lc.critic_tau,
            lc.max_grad_norm, list(lc.log_std_bounds), lc.nstep, lc.gradient_steps_per_iteration, lc.horizon) == (
        8192, 5_000_000, 5e-4, 5e-4, 5e-3, 1.0, 0.01, 0.5, [-20.0, 2.0], 4, 4, 1)
    assert default.env.num_envs == 4096 and default.max_iterations == 122071  # sac_best.sh
    assert (mt50.loss.nstep, mt50.loss.gradient_steps_per_iteration, mt50.max_iterations) == (16, 32, 61036)
    assert list(paper.arch.kwargs.hidden) == [512, 256, 128] and paper.arch.kwargs.activation == "relu"
    assert cpu.loss.replay_buffer_size >= cpu.loss.batch_size and cpu.torch_threads == 1
    # MTBench's discount everywhere but the CPU preset (0.95: docs/off_policy.md, "Measured on the CPU")
    assert (default.loss.gamma, mt50.loss.gamma, cpu.loss.gamma) == (0.99, 0.99, 0.95)


# ---------------------------------------------------------------------------------------------- front door
SMALL_ARCHS = {
    "multihead": ["arch.kwargs.hidden=[32,32]"],
    "soft_modularization": ["arch.kwargs.hidden_dim=32", "arch.kwargs.state_encoder=[32]", "arch.kwargs.task_encoder=[32]"],
    "care": ["arch.kwargs.hidden=[32,32]"],
    "paco": ["arch.kwargs.hidden_dim=32"],
    "moore_mh": ["arch.kwargs.hidden_dim=32"],
}


@pytest.mark.parametrize("arch", sorted(SMALL_ARCHS))
def test_architectures_serve_as_actor_and_q_networks(tmp_path: Path, arch: str):
    trainer = build_trainer(_cfg(tmp_path, f"arch={arch}", *SMALL_ARCHS[arch], "max_iterations=5",
                                 "loss.warmup_steps=0"), env=_env())
    history = trainer.train()
    assert trainer.updates == 2 * 2 and math.isfinite(history[-1]["loss/qvalue"])


@pytest.mark.parametrize("grad", ["pcgrad", "cagrad", "famo", "none"])
def test_gradient_methods_plug_into_the_off_policy_loop(tmp_path: Path, grad: str):
    trainer = build_trainer(_cfg(tmp_path, f"grad={grad}", "grad.diagnostics_every=1", "max_iterations=5"),
                            env=_env())
    assert trainer.update_module is not trainer.loss
    metrics = trainer.train()[-1]
    assert metrics["train/skipped_updates"] == 0 and math.isfinite(metrics["loss/qvalue"])
    assert -1.0 <= metrics["train/grad_cos_critic_mean"] <= 1.0 and -1.0 <= metrics["train/grad_cos_actor_mean"] <= 1.0


def test_front_door_prints_the_success_table_and_resumes(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                         monkeypatch: pytest.MonkeyPatch):
    from mtbench.logging import read_scalars
    from mtbench.trainer.run import run

    monkeypatch.chdir(tmp_path)
    trainer = run(_cfg(tmp_path, "max_iterations=6", "checkpoint.every=3"), env=_env())
    out = capsys.readouterr().out
    assert "mtbench | sac arch=mlp grad=none" in out and "2 updates of 32 replayed 4-step transitions" in out
    assert "Per-task success" in out and "task2" in out and trainer.iteration == 6
    resumed = run(_cfg(tmp_path, "max_iterations=8", f"resume={tmp_path / 'ckpt' / 'ckpt_000006.pt'}"), env=_env())
    assert "resumed from" in capsys.readouterr().out and resumed.iteration == 8
    scalars = read_scalars(tmp_path / "runs")
    assert [step for step, _ in scalars["frames"]] == [12 * i for i in range(1, 9)]
    assert "loss/qvalue" in scalars and "alpha/task0" in scalars
