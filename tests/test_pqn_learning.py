"""A short seeded MT-PQN run on the real physics env learns: return and success on ``reach`` rise far above those of
the first iterations (epsilon ~1: a random bang-off-bang policy); and the stock-TorchRL sketch of docs/pqn.md runs.
On the real env, a greedy rollout is consistent with the Q network: the stored bins are its per-dimension arg-max on
the stored observations, the physics receives them mapped to {-1, 0, +1}, and the targets are the hand-computed
Peng's Q(lambda) recursion (per-step observations and MTBench's held observation).

Settings: 32 reach worlds, 60-step episodes, the env's 1 cm action scale, the residual MLP (D=128), lr 3e-3
annealed, 100 iterations of 16 steps (51,200 frames), and conf/loss/pqn.yaml's defaults otherwise: per-task input
and value normalisation, gamma 0.95, lambda 0.9, epsilon 1 -> 0.05 over the first 10% of the frames. Measured
2026-11-29 (seed 0, ~35 s on 2 busy CPU cores): the first 10 iterations had a mean return of 10.9 and success 0.01,
the last 20 a return of 283.5 and success 0.90 (seeds 1 and 2: 281 / 0.94 and 319 / 0.98; with the defaults of
before, gamma 0.99 and no value normalisation: 70.2 / 0.54 for seed 0); the thresholds (return x3, success +0.1)
leave a wide margin.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import torch

from cpu_runs import compose_config, one_torch_thread, run_doc_snippet, train_on_cpu
from mtbench.modules import greedy_value
from mtbench.trainer import build_trainer
from mtbench.trainer.rollout import base_env
from test_pqn import _hand_peng_q_lambda


def _window(key: str, rows: list[dict[str, float]]) -> float:
    values = [r[key] for r in rows if math.isfinite(r[key])]  # NaN: no episode finished yet
    return sum(values) / len(values)


@pytest.mark.slow
def test_seeded_cpu_pqn_run_learns_reach(tmp_path: Path) -> None:
    overrides = [
        "device=cpu", "seed=0", "loss=pqn", "env.name=reach", "env.num_envs=32", "++env.overrides.episode_length=60",
        "++env.overrides.action_scale=0.01", "arch=residual_mlp", "arch.kwargs.hidden_dim=128", "loss.horizon=16",
        "loss.epochs=4", "loss.minibatch_size=128", "loss.lr=3e-3", "loss.lmbda=0.9", "loss.normalize_input=true",
        "loss.end_epsilon=0.05", "loss.exploration_fraction=0.1", "loss.epsilon_clock=frames",
        "loss.hold_observation=false", "max_iterations=100", "logging.progress=none",
        "checkpoint.every=0", "checkpoint.save_final=false", f"checkpoint.dir={tmp_path}", "torch_threads=1",
    ]
    _, history = train_on_cpu(overrides)
    first, last = history[:10], history[-20:]
    r0, r1 = _window("return/mean", first), _window("return/mean", last)
    s0, s1 = _window("success/mean", first), _window("success/mean", last)
    print(f"reach: return {r0:.1f} -> {r1:.1f}, success {s0:.2f} -> {s1:.2f}")
    assert r1 > 3.0 * r0, (r0, r1)
    assert s1 > s0 + 0.1, (s0, s1)


def test_stock_torchrl_pipeline_of_the_docs_runs_on_the_real_env() -> None:
    """The "Using the parts in a stock TorchRL pipeline" sketch of docs/pqn.md, on 8 CPU worlds of reach."""
    scope = run_doc_snippet("pqn.md", (('"cuda", 8192, 16, 50_000', '"cpu", 8, 16, 3'), ('"mt10_rand"', '"reach"'),
                                       ("hidden_dim=256", "hidden_dim=32")))
    assert scope["i"] == 2 and scope["rollout"].batch_size == (8, 16)
    assert scope["rollout"]["action"].dtype == torch.int64 and torch.isfinite(scope["rollout"]["value_target"]).all()
    assert torch.isfinite(scope["out"]["loss_qvalue"])
    optim, policy = scope["optim"], scope["policy"]
    assert all(int(optim.state[p]["step"]) == 3 * 8 * 4 for p in scope["loss"].parameters())  # 3 x 8 epochs x 4
    assert float(policy[-1].eps) == pytest.approx(0.005)  # annealed to its end value
    assert optim.param_groups[0]["lr"] == 3e-4 * (1 - 2 / 3)


@pytest.mark.parametrize("hold", [False, True])
def test_greedy_rollout_on_the_real_env_is_consistent_with_the_q_network(tmp_path: Path, hold: bool) -> None:
    """8 reach worlds, 20-step episodes (episode ends inside the 16-step window), the paper's 0.005 m action scale,
    after 2 iterations of training; then one greedy rollout (epsilon 0)."""
    cfg = compose_config([
        "device=cpu", "seed=0", "loss=pqn", "env.name=reach", "env.num_envs=8", "++env.overrides.episode_length=20",
        "++env.overrides.action_scale=0.005", "arch=residual_mlp", "arch.kwargs.hidden_dim=64", "loss.horizon=16",
        "loss.epochs=2", "loss.minibatch_size=64", "loss.gamma=0.99", "loss.lmbda=0.5", "max_iterations=2",
        "loss.normalize_input=false", "loss.normalize_value=false",
        f"loss.hold_observation={str(hold).lower()}", "loss.epsilon_clock=frames", "logging.progress=none",
        "logging.logger=none", "checkpoint.every=0", "checkpoint.save_final=false", f"checkpoint.dir={tmp_path}",
    ])
    with one_torch_thread():
        trainer = build_trainer(cfg)
        trainer.train()
        base = base_env(trainer.env)
        executed: list[torch.Tensor] = []
        step = base._step
        base._step = lambda td: (executed.append(td["action"].clone()), step(td))[1]
        trainer.policy[-1].eps.fill_(0.0)
        data = trainer.rollout.collect().clone()
        target = trainer.advantage(data)["value_target"][..., 0]
    q = trainer.policy[0]
    obs, nxt = data["observation"], data["next", "observation"]
    done, truncated = data["next", "done"][..., 0], data["next", "truncated"][..., 0]
    assert done.any() and not data["next", "terminated"].any()  # time limits only
    with torch.no_grad():
        values = q(data.select("observation", "task_id").clone())["action_value"]
        last = data[:, -1].select("task_id").clone().set("observation", nxt[:, -1].nan_to_num())
        value_last = greedy_value(q(last)["action_value"])
    assert torch.equal(data["action"], values.argmax(-1))  # acting = arg-max of the Q network on the stored input
    assert torch.equal(torch.stack(executed, 1), data["action"].float() - 1.0)  # what the physics received
    if hold:
        assert torch.equal(obs, obs[:, :1].expand_as(obs))
        assert torch.equal(data["action"], data["action"][:, :1].expand_as(data["action"]))
    else:
        assert torch.equal(obs[:, 1:][~done[:, :-1]], nxt[:, :-1][~done[:, :-1]])
    v = greedy_value(values)
    boot_next = torch.cat([v[:, 1:], value_last[:, None]], 1)
    expected = _hand_peng_q_lambda(data["next", "reward"][..., 0], boot_next, v, done, truncated, 0.99, 0.5)
    torch.testing.assert_close(target, expected)
