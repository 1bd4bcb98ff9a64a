"""MT-PQN: bang-off-bang discrete actions, the decomposed Q network and its epsilon-greedy policy, Peng's Q(lambda)
(known answers from the reference, a termination and truncations inside the window, stock TorchRL TD(lambda)),
the loss, the schedules, clear errors, loss=pqn through build_trainer (exact resume, non-finite guard with RAdam,
PCGrad). The seeded learning run on the real reach env is tests/test_pqn_learning.py (each file stays under 60 s)."""

from __future__ import annotations

import copy
import math
import os
import signal
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
import torch
from hydra import compose, initialize_config_dir
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.data import Categorical
from torchrl.envs import TransformedEnv
from torchrl.modules import EGreedyModule, QValueModule
from torchrl.objectives.value import TDLambdaEstimator

from cpu_runs import assert_same_metrics
from envs_for_tests import SyntheticMTEnv
from host_sync import allow_capturable_on_cpu, forbid_host_sync
from test_trainer import _cfg as trainer_cfg
from test_trainer import _env
from mtbench.envs import DiscreteActions, bin_values, make_env
from mtbench.envs.metaworld import MetaWorldEnv
from mtbench.modules import decomposed_q_value, greedy_value, make_q_network, make_q_policy
from mtbench.objectives import MTPQNLoss, PengQLambda, compute_gradients, make_gradient_method, peng_q_lambda
from mtbench.paper.rows import compose_row
from mtbench.trainer import EpsilonSchedule, LinearLRDecay, NonFiniteGuard, TrainerHook, build_trainer
from mtbench.trainer.hooks.schedules import linear_epsilon
from mtbench.trainer.skip_found_inf import RAdam
from mtbench.trainer.update import MinibatchUpdate

CONF = str(Path(__file__).resolve().parents[1] / "conf")


# ------------------------------------------------------------------------------------------ discrete actions
def test_bin_values_known_answers() -> None:
    assert bin_values(3).tolist() == [-1.0, 0.0, 1.0]  # bang-off-bang
    assert bin_values(2).tolist() == [-1.0, 1.0]
    assert bin_values(5).tolist() == [-1.0, -0.5, 0.0, 0.5, 1.0]
    b = torch.arange(7, dtype=torch.float64)
    torch.testing.assert_close(bin_values(7), b * 2.0 / 6 - 1.0)  # MTBench: action * spacing - 1
    assert bin_values(3, -0.5, 0.5).tolist() == [-0.5, 0.0, 0.5]


def _discrete_synthetic(bins: int, action_dim: int = 3) -> TransformedEnv:
    env = TransformedEnv(SyntheticMTEnv([2, 2], action_dim=action_dim, seed=0), DiscreteActions(bins))
    env.__dict__["_torchrl_native_autoreset"] = True
    return env


@pytest.mark.parametrize("bins", [2, 3, 5])
def test_discrete_actions_spec_and_map(bins: int) -> None:
    env = _discrete_synthetic(bins)
    spec = env.action_spec
    assert type(spec) is Categorical and spec.n == bins and spec.shape == (4, 3) and spec.dtype == torch.int64
    sample = spec.rand()
    assert sample.shape == (4, 3) and 0 <= int(sample.min()) and int(sample.max()) < bins
    td = env.reset()
    action = torch.arange(12).reshape(4, 3) % bins
    td["action"] = action
    seen = []
    original = env.base_env._step
    env.base_env._step = lambda t: (seen.append(t["action"].clone()), original(t))[1]
    out, _ = env.step_and_maybe_reset(td)
    assert torch.equal(out["action"], action)  # the rollout keeps the bins
    torch.testing.assert_close(seen[0], bin_values(bins).float()[action])  # the env receives the mapped values
    assert env.transform.state_dict() == {}  # derived from the spec: nothing to checkpoint


def test_meta_world_physics_receives_the_mapped_action() -> None:
    env = make_env("reach", num_envs=4, device="cpu", actions="discrete", bins=3, episode_length=20,
                   action_scale=0.005, random_start_progress=False)
    base = env.base_env
    assert isinstance(base, MetaWorldEnv) and base.action_scale == 0.005 and env.max_episode_steps == 20
    assert type(env.action_spec) is Categorical and env.action_spec.shape == (4, 4) and env.action_spec.n == 3
    td = env.reset()
    bins = torch.tensor([[0, 1, 2, 1], [2, 2, 2, 0], [1, 1, 1, 1], [0, 0, 0, 2]])
    td["action"] = bins
    mocap_before = torch.cat([s.sim.mocap_pos[:, 0].clone() for _, s in base.blocks])
    env.step_and_maybe_reset(td)
    expected = bins.float() - 1.0  # 3 bins: b - 1
    assert torch.equal(base._action, expected)  # the action the physics stage applied
    ctrl = torch.cat([s.sim.ctrl[:, 0] for _, s in base.blocks])
    assert torch.equal(ctrl, -expected[:, 3])  # gripper: +1 closes (tendon force -1), 0 is no force
    mocap_after = torch.cat([s.sim.mocap_pos[:, 0] for _, s in base.blocks])
    moved = mocap_after - mocap_before
    inside = (moved.abs() < 0.0051).all()  # clipped at the workspace edge at most
    assert inside and torch.allclose(moved[2], torch.zeros(3))
    torch.testing.assert_close(moved[0, :2], expected[0, :2] * 0.005)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(actions="discrete", bins=1), "bins must be an integer >= 2"),
        (dict(actions="discrete", bins=2.5), "bins must be an integer >= 2"),
        (dict(actions="binary"), r"unknown actions 'binary'; valid choices: \['continuous', 'discrete'\]"),
        (dict(bins=3), "bins=3 is only used with actions='discrete'"),
        (dict(action_scale=0.0), "action_scale must be a number > 0"),
    ],
)
def test_make_env_errors(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make_env("reach", num_envs=2, device="cpu", **kwargs)


def test_discrete_parkour_is_refused() -> None:
    with pytest.raises(ValueError, match="actions='discrete' is available for Meta-World settings only"):
        make_env("parkour_flat", device="cpu", actions="discrete")


# ------------------------------------------------------------------------------------------ Q network, policy
def _utilities() -> torch.Tensor:
    # 2 states, 3 action dimensions, 3 bins
    return torch.tensor([[[0.1, 0.5, -1.0], [2.0, 0.0, 1.0], [-3.0, -2.0, -2.5]],
                         [[1.0, 1.0, 4.0], [0.3, 0.2, 0.1], [0.0, 9.0, 8.0]]])


def test_greedy_action_and_decomposed_values_known_answers() -> None:
    q = _utilities()
    out = QValueModule(action_space="categorical", strict_shape=False)(TensorDict({"action_value": q}, [2]))
    assert out["action"].tolist() == [[1, 0, 1], [2, 0, 1]]  # per-dimension arg-max
    torch.testing.assert_close(greedy_value(q), torch.tensor([(0.5 + 2.0 - 2.0) / 3, (4.0 + 0.3 + 9.0) / 3]))
    action = torch.tensor([[0, 2, 2], [1, 1, 0]])
    torch.testing.assert_close(decomposed_q_value(q, action), torch.tensor([(0.1 + 1.0 - 2.5) / 3, (1.0 + 0.2) / 3]))
    # Q(s, greedy a) = V(s)
    torch.testing.assert_close(decomposed_q_value(q, out["action"]), greedy_value(q))


class FixedUtilities(nn.Module):
    """A "Q network" returning given utilities (``action_value``) for every observation row."""

    def __init__(self, utilities: torch.Tensor) -> None:
        super().__init__()
        self.register_buffer("utilities", utilities)

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        return self.utilities[observation[..., 0].long()]


def test_epsilon_greedy_policy_explores_per_world_all_dimensions_jointly() -> None:
    n, a, bins = 2000, 8, 2
    utilities = torch.zeros(1, a, bins)
    utilities[..., 1] = 1.0  # greedy: bin 1 everywhere
    q = TensorDictModule(FixedUtilities(utilities), in_keys=["observation", "task_id"], out_keys=["action_value"])
    policy = make_q_policy(q, Categorical(bins, shape=(n, a)), eps_init=0.5)
    explore = next(m for m in policy.modules() if isinstance(m, EGreedyModule))
    td = TensorDict({"observation": torch.zeros(n, 3), "task_id": torch.zeros(n, dtype=torch.long)}, [n])
    torch.manual_seed(0)
    greedy_rows = (policy(td.clone())["action"] == 1).all(-1).float().mean().item()
    # one draw per world: ~0.5 greedy rows (+ 0.5 / 2^8 random rows that are all 1); per-dimension draws: 0.75^8 = 0.1
    assert 0.45 < greedy_rows < 0.56
    explore.eps.fill_(0.0)
    assert (policy(td.clone())["action"] == 1).all()
    explore.eps.fill_(1.0)
    from tensordict.nn import InteractionType, set_interaction_type

    with set_interaction_type(InteractionType.DETERMINISTIC):  # evaluation: greedy whatever eps
        assert (policy(td.clone())["action"] == 1).all()


def test_q_network_over_any_arch_outputs_per_dimension_utilities() -> None:
    for arch, kwargs in (("mlp", {"hidden": [8]}), ("moore", {"num_experts": 2, "num_layers": 1, "hidden_dim": 8}),
                         ("multihead", {"hidden": [8]}), ("residual_mlp", {"hidden_dim": 8})):
        q = make_q_network(arch, obs_dim=7, action_dim=4, bins=3, num_tasks=3, **kwargs)
        td = TensorDict({"observation": torch.randn(5, 7), "task_id": torch.tensor([0, 1, 2, 0, 1])}, [5])
        assert q(td)["action_value"].shape == (5, 4, 3), arch
    with pytest.raises(ValueError, match="bins must be an integer >= 2"):
        make_q_network("mlp", obs_dim=7, action_dim=4, bins=1, num_tasks=3)


# ------------------------------------------------------------------------------------------ Peng's Q(lambda)
REF_R = torch.tensor([1.0, 0.0, 2.0, 1.0])
REF_TERM = torch.tensor([False, False, True, False])
REF_BOOT = torch.tensor([0.5, 0.3, 0.7, 0.4])  # V(s_1), V(s_2), V(s_3), V(s_4)


@pytest.mark.parametrize(("lmbda", "expected"), [(0.0, [1.45, 0.27, 2.0, 1.36]), (0.5, [1.69075, 1.035, 2.0, 1.36]),
                                                 (1.0, [2.62, 1.8, 2.0, 1.36])])
def test_peng_q_lambda_reference_values(lmbda: float, expected: list[float]) -> None:
    # docs reference mtrl-algorithms.md §2.4 (verified numbers, gamma = 0.9, a termination at t = 2)
    g = peng_q_lambda(REF_R[:, None], REF_BOOT[:, None], REF_TERM[:, None], REF_TERM[:, None], 0.9, lmbda, time_dim=0)
    torch.testing.assert_close(g[:, 0], torch.tensor(expected))
    with pytest.raises(ValueError, match="same shape"):
        peng_q_lambda(REF_R, REF_BOOT[:3], REF_TERM, REF_TERM, 0.9, lmbda, time_dim=0)


OFFSETS = torch.tensor([[-1.0, 0.0, -2.0], [0.0, -3.0, -1.0]])  # per-dimension max 0: V(s) = observation[0]


class ValueAsFirstFeature(nn.Module):
    """Utilities ``observation[0] + OFFSETS``: the greedy value is ``observation[..., 0]``."""

    def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
        return observation[..., 0, None, None] + OFFSETS


def _q_module() -> TensorDictModule:
    return TensorDictModule(ValueAsFirstFeature(), in_keys=["observation", "task_id"], out_keys=["action_value"])


def _rollout(values: list[list[float]], last: list[float], reward: list[list[float]], terminated: list[list[bool]],
             truncated: list[list[bool]]) -> TensorDict:
    """A ``[N, T]`` native-autoreset rollout whose observations carry ``V(s)`` in feature 0; ``("next",
    "observation")[t] = observation[t + 1]`` (``last`` at ``T - 1``), NaN on done steps."""
    v = torch.tensor(values)
    n, t = v.shape
    obs = torch.stack([v, torch.zeros(n, t)], -1)
    nxt = torch.stack([torch.cat([v[:, 1:], torch.tensor(last)[:, None]], 1), torch.zeros(n, t)], -1)
    term, trunc = torch.tensor(terminated)[..., None], torch.tensor(truncated)[..., None]
    done = term | trunc
    nxt[done[..., 0]] = float("nan")
    return TensorDict({"observation": obs, "task_id": torch.zeros(n, t, dtype=torch.long),
                       "next": {"observation": nxt, "reward": torch.tensor(reward)[..., None], "done": done,
                                "terminated": term, "truncated": trunc}}, [n, t])


def test_peng_q_lambda_estimator_with_a_termination_and_truncations_inside_the_window() -> None:
    f, t = False, True
    rollout = _rollout(
        values=[[9.0, 0.5, 0.3, 0.7], [2.0, 3.0, 5.0, 7.0], [1.0, 2.0, 3.0, 4.0]],
        last=[0.4, 11.0, 99.0],
        reward=[[1.0, 0.0, 2.0, 1.0], [1.0, 1.0, 1.0, 1.0], [0.0, 0.0, 0.0, 1.0]],
        terminated=[[f, f, t, f], [f, f, f, f], [f, f, f, f]],
        truncated=[[f, f, f, f], [f, t, f, f], [f, f, f, t]],
    )
    est = PengQLambda(gamma=0.9, lmbda=0.5, value_network=_q_module())
    out = est(rollout.clone(False))["value_target"][..., 0]
    # env 0: the reference (termination at t = 2); env 1: truncation at t = 1 bootstraps V(s_1) and cuts the
    # trace: G_3 = 1 + .9 * 11 = 10.9, G_2 = 1 + .9 (.5 * 10.9 + .5 * 7), G_1 = 1 + .9 * 3,
    # G_0 = 1 + .9 (.5 G_1 + .5 * 3); env 2: truncation at the last step (NaN next observation) bootstraps V(s_3) = 4
    expected = torch.tensor([[1.69075, 1.035, 2.0, 1.36],
                             [1.0 + 0.9 * (0.5 * 3.7 + 0.5 * 3.0), 3.7, 9.055, 10.9],
                             [2.291175, 3.0915, 3.87, 4.6]])
    torch.testing.assert_close(out, expected)
    assert torch.isfinite(out).all()


def test_peng_q_lambda_equals_stock_td_lambda_on_the_greedy_value() -> None:
    """Without truncations, Peng's Q(lambda) is TorchRL's TD(lambda) with V(s) = max_a Q(s, a)."""
    g = torch.Generator().manual_seed(0)
    n, t = 5, 9
    v = torch.randn(n, t + 1, generator=g)
    term = torch.rand(n, t, 1, generator=g) < 0.2
    obs = torch.stack([v, torch.zeros_like(v)], -1)
    rollout = TensorDict({"observation": obs[:, :-1], "task_id": torch.zeros(n, t, dtype=torch.long),
                          "next": {"observation": obs[:, 1:], "task_id": torch.zeros(n, t, dtype=torch.long),
                                   "reward": torch.randn(n, t, 1, generator=g),
                                   "done": term.clone(), "terminated": term, "truncated": torch.zeros_like(term)}},
                         [n, t])

    class Greedy(nn.Module):
        def forward(self, observation: torch.Tensor, task_id: torch.Tensor) -> torch.Tensor:
            return greedy_value(ValueAsFirstFeature()(observation, task_id)).unsqueeze(-1)

    stock = TDLambdaEstimator(gamma=0.97, lmbda=0.7, value_network=TensorDictModule(
        Greedy(), in_keys=["observation", "task_id"], out_keys=["state_value"]))
    ours = PengQLambda(gamma=0.97, lmbda=0.7, value_network=_q_module())
    expected = stock(rollout.clone())["value_target"]
    torch.testing.assert_close(ours(rollout.clone())["value_target"], expected)


def test_per_task_value_normalisation_targets_and_statistics() -> None:
    """With normalize_value the network's greedy values are de-normalised per task, the targets are computed in the
    reward's scale (the plain estimator's targets on the de-normalised values), the task's statistics are updated
    with its own targets only, and the written targets are normalised with the updated statistics."""
    g = torch.Generator().manual_seed(3)
    n, t = 6, 5
    v = torch.randn(n, t + 1, generator=g)
    term = torch.rand(n, t, 1, generator=g) < 0.2
    trunc = (torch.rand(n, t, 1, generator=g) < 0.2) & ~term
    task = torch.tensor([0, 0, 1, 1, 2, 2])[:, None].expand(n, t)
    obs = torch.stack([v, torch.zeros_like(v)], -1)
    reward = 10.0 * torch.randn(n, t, 1, generator=g) + 3.0 * task[..., None]
    rollout = TensorDict({"observation": obs[:, :-1], "task_id": task.clone(),
                          "next": {"observation": obs[:, 1:], "reward": reward, "done": term | trunc,
                                   "terminated": term, "truncated": trunc}}, [n, t])
    est = PengQLambda(gamma=0.9, lmbda=0.5, value_network=_q_module(), num_tasks=3, normalize_value=True)
    mean0, std0 = torch.tensor([1.0, -2.0, 5.0]), torch.tensor([2.0, 0.5, 4.0])
    est.value_norm.mean.copy_(mean0[:, None].double())
    est.value_norm.var.copy_((std0[:, None] ** 2 - 1e-5).double())
    est.value_norm.count.fill_(100.0)
    out = est(rollout.clone())["value_target"]

    # the same rollout with the de-normalised values in feature 0, through the plain estimator
    raw = rollout.clone()
    scale, shift = std0[task], mean0[task]
    raw["observation"][..., 0] = v[:, :-1] * scale + shift
    raw["next", "observation"][..., 0] = v[:, 1:] * scale + shift
    targets = PengQLambda(gamma=0.9, lmbda=0.5, value_network=_q_module())(raw)["value_target"]
    for k in range(3):
        x = targets[task == k].double()
        n_a, n_b = 100.0, x.numel()
        mean_b, var_b = x.mean(), x.var(unbiased=False)
        delta = mean_b - mean0[k].double()
        mean = mean0[k].double() + delta * n_b / (n_a + n_b)
        var = ((std0[k].double() ** 2 - 1e-5) * n_a + var_b * n_b + delta ** 2 * n_a * n_b / (n_a + n_b)) / (n_a + n_b)
        torch.testing.assert_close(est.value_norm.mean[k, 0], mean)
        torch.testing.assert_close(est.value_norm.var[k, 0], var)
        torch.testing.assert_close(out[task == k], ((x - mean) / (var + 1e-5).sqrt()).float())
    assert torch.isfinite(out).all()


def test_value_normalisation_is_in_the_loss_state_and_needs_num_tasks() -> None:
    loss = MTPQNLoss(_q_module(), num_tasks=4, normalize_value=True)
    assert loss.value_estimator.value_norm.num_tasks == 4
    state = loss.state_dict()
    assert {"_value_estimator.value_norm.mean", "_value_estimator.value_norm.var",
            "_value_estimator.value_norm.count"} <= set(state)
    assert "task_id" in loss.value_estimator.in_keys
    assert MTPQNLoss(_q_module()).value_estimator.value_norm is None
    with pytest.raises(ValueError, match="normalize_value=True needs num_tasks"):
        MTPQNLoss(_q_module(), normalize_value=True)


# ------------------------------------------------------------------------------------------ loss
def test_loss_is_the_squared_error_of_the_mean_chosen_utility() -> None:
    torch.manual_seed(0)
    q = make_q_network("mlp", obs_dim=6, action_dim=3, bins=3, num_tasks=2, hidden=[16])
    loss = MTPQNLoss(q, reduction="none")
    batch = TensorDict({"observation": torch.randn(10, 6), "task_id": torch.arange(10) % 2,
                        "action": torch.randint(0, 3, (10, 3)), "value_target": torch.randn(10, 1)}, [10])
    out = loss(batch)
    with torch.no_grad():
        chosen = q(batch.clone())["action_value"].gather(-1, batch["action"][..., None])[..., 0].mean(-1)
    expected = (chosen - batch["value_target"][:, 0]) ** 2
    assert out["loss_qvalue"].shape == (10,)
    torch.testing.assert_close(out["loss_qvalue"], expected)
    loss.reduction = "mean"
    torch.testing.assert_close(loss(batch)["loss_qvalue"], expected.mean())
    torch.testing.assert_close(loss(batch)["td_error"], (chosen - batch["value_target"][:, 0]).abs().mean())
    assert set(loss.in_keys) == {"observation", "task_id", "action", "value_target"}
    with pytest.raises(KeyError, match="value_estimator"):
        loss(batch.exclude("value_target"))


def test_every_key_is_settable_and_forwarded_to_the_estimator() -> None:
    q = TensorDictModule(ValueAsFirstFeature(), in_keys=["obs", "tid"], out_keys=["av"])
    loss = MTPQNLoss(q, gamma=0.9, lmbda=0.5)
    loss.set_keys(action="act", value_target="vt", reward="rew", done="dn", terminated="term", truncated="trunc",
                  task_id="tid")
    est = loss.value_estimator
    assert isinstance(est, PengQLambda) and est.tensor_keys.action_value == "av"
    assert (est.tensor_keys.value_target, est.tensor_keys.reward, est.tensor_keys.truncated) == ("vt", "rew", "trunc")
    f, t = False, True
    ref = _rollout([[9.0, 0.5, 0.3, 0.7]], [0.4], [[1.0, 0.0, 2.0, 1.0]], [[f, f, t, f]], [[f, f, f, f]])
    renamed = ref.clone()
    for old, new in (("observation", "obs"), ("task_id", "tid")):
        renamed.rename_key_(old, new)
    for old, new in (("observation", "obs"), ("reward", "rew"), ("done", "dn"), ("terminated", "term"),
                     ("truncated", "trunc")):
        renamed.rename_key_(("next", old), ("next", new))
    out = est(renamed)
    torch.testing.assert_close(out["vt"][0, :, 0], torch.tensor([1.69075, 1.035, 2.0, 1.36]))
    out.set("act", torch.zeros(1, 4, 2, dtype=torch.long))
    assert math.isfinite(float(loss(out.reshape(-1))["loss_qvalue"]))
    assert {"obs", "tid", "act", "vt"} == set(loss.in_keys)


@pytest.mark.parametrize(
    ("build", "error", "message"),
    [
        (lambda q: MTPQNLoss(q, reduction="avg"), ValueError, r"unknown reduction 'avg'; valid choices"),
        (lambda q: MTPQNLoss(q, loss_function="huber"), ValueError, r"unknown loss_function 'huber'; valid choices"),
        (lambda q: MTPQNLoss(q.module), TypeError, "value_network must be a TensorDictModule"),
        (lambda q: PengQLambda(gamma=0.99, lmbda=1.5, value_network=q), ValueError, r"lmbda must be in \[0, 1\]"),
        (lambda q: PengQLambda(gamma=0.0, lmbda=0.5, value_network=q), ValueError, r"gamma must be in \(0, 1\]"),
        (lambda q: MTPQNLoss(q).make_value_estimator("td0"), ValueError, "takes None"),
    ],
)
def test_loss_and_estimator_errors(build: Any, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        build(_q_module())


# ------------------------------------------------------------------------------------------ schedules, RAdam
def test_epsilon_schedule_known_answers() -> None:
    assert linear_epsilon(0, 1.0, 0.005, 1000) == 1.0
    assert linear_epsilon(500, 1.0, 0.005, 1000) == pytest.approx(0.5025)
    assert linear_epsilon(1000, 1.0, 0.005, 1000) == pytest.approx(0.005)
    assert linear_epsilon(10**9, 1.0, 0.005, 1000) == 0.005
    # paper sizes: 50,000 iterations x 8192 envs x 16 steps, 0.5% -> annealed over the first 250 iterations
    explore = EGreedyModule(Categorical(3, shape=(8192, 4)), eps_init=1.0, eps_end=0.005)
    fake = SimpleNamespace(policy=nn.Sequential(explore), frames=0, num_envs=8192, total_envs=8192,
                           total_iterations=50_000, frames_per_batch=8192 * 16, rollout=SimpleNamespace(steps_done=0))
    hook = EpsilonSchedule(1.0, 0.005, 0.005)
    assert hook.anneal_frames(fake) == 250 * 8192 * 16
    hook.on_iteration_start(fake)
    assert float(explore.eps) == 1.0
    fake.frames = 125 * 8192 * 16  # half-way, before step 0 of iteration 126
    hook.on_iteration_start(fake)
    assert float(explore.eps) == pytest.approx(0.5025)
    hook.on_rollout_step(fake, 8, 16)  # before step 8: 8 more env steps of every world
    assert hook.epsilon == pytest.approx(1.0 - 0.995 * (125 * 16 + 8) / (250 * 16))
    assert float(explore.eps) == pytest.approx(hook.epsilon)
    metrics: dict[str, float] = {}
    hook.on_iteration_end(fake, metrics)
    assert metrics["train/epsilon"] == hook.epsilon
    with pytest.raises(ValueError, match="end_epsilon <= start_epsilon"):
        EpsilonSchedule(0.1, 0.5)
    with pytest.raises(TypeError, match="needs an EGreedyModule"):
        EpsilonSchedule().on_train_start(SimpleNamespace(policy=nn.Sequential(nn.Identity())))


def test_epsilon_schedule_on_mtbench_clock_known_answers() -> None:
    """MTBench's ``pqn_agent.py``: ``t = (epoch - 1) * num_envs + num_envs * (step + 1)`` against ``fraction *
    iterations * num_envs * horizon``: at the paper's sizes the rate reaches its end after 4,000 iterations, not
    250 (the frames clock)."""
    explore = EGreedyModule(Categorical(3, shape=(8192, 4)), eps_init=1.0, eps_end=0.005)
    fake = SimpleNamespace(policy=nn.Sequential(explore), frames=0, iteration=0, num_envs=8192, total_envs=8192,
                           total_iterations=50_000, frames_per_batch=8192 * 16, rollout=SimpleNamespace(steps_done=0))
    hook = EpsilonSchedule(1.0, 0.005, 0.005, clock="mtbench")
    hook.on_iteration_start(fake)  # epoch 1, step 0: t = 8192
    assert hook.epsilon == pytest.approx(1.0 - 0.995 / 4000)
    fake.iteration, fake.frames = 2000, 2000 * 8192 * 16
    hook.on_rollout_step(fake, 8, 16)  # epoch 2001, before step 8: t = 8192 * (2000 + 8 + 1)
    assert hook.epsilon == pytest.approx(1.0 - 0.995 * 2009 / 4000) and float(explore.eps) == pytest.approx(
        hook.epsilon)
    frames_clock = EpsilonSchedule(1.0, 0.005, 0.005)
    frames_clock.on_rollout_step(fake, 8, 16)
    assert frames_clock.epsilon == 0.005  # 2000 iterations are far past the frames clock's 250
    fake.iteration = 3984
    hook.on_iteration_start(fake)
    assert hook.epsilon == pytest.approx(0.005 + 0.995 * 15 / 4000)  # t = 8192 * 3985
    hook.on_rollout_step(fake, 15, 16)
    assert hook.epsilon == pytest.approx(0.005)  # t = 8192 * 4000: the end
    state = hook.state_dict()
    assert state["clock"] == "mtbench"
    restored = EpsilonSchedule()
    restored.load_state_dict(state)
    assert (restored.clock, restored.epsilon) == ("mtbench", hook.epsilon)
    restored.load_state_dict({k: v for k, v in state.items() if k != "clock"})  # a checkpoint from before the option
    assert restored.clock == "frames"
    with pytest.raises(ValueError, match=r"unknown epsilon clock 'steps'; valid choices: \['frames', 'mtbench'\]"):
        EpsilonSchedule(clock="steps")


def test_linear_lr_decay_known_answers() -> None:
    p = nn.Parameter(torch.zeros(2))
    opt = RAdam([p], lr=torch.tensor(3e-4))
    fake = SimpleNamespace(optimizer=opt, iteration=0, total_iterations=50_000)
    hook = LinearLRDecay(3e-4)
    lr = opt.param_groups[0]["lr"]
    for iteration, expected in ((0, 3e-4), (25_000, 1.5e-4), (49_999, 3e-4 / 50_000)):
        fake.iteration = iteration
        hook.on_iteration_start(fake)
        assert opt.param_groups[0]["lr"] is lr and float(lr) == pytest.approx(expected)  # in place


@pytest.mark.parametrize("capturable", [False, True])
def test_radam_skips_a_step_on_found_inf_exactly(monkeypatch: pytest.MonkeyPatch, capturable: bool) -> None:
    """Also on the ``capturable=True`` path (the one a CUDA graph captures; run here on the CPU)."""
    if capturable:
        allow_capturable_on_cpu(monkeypatch)
    torch.manual_seed(0)
    p, q = nn.Parameter(torch.randn(5)), nn.Parameter(torch.zeros(5))
    q.data.copy_(p.data)
    ours = RAdam([p], lr=torch.tensor(1e-2), capturable=capturable)
    stock = torch.optim.RAdam([q], lr=torch.tensor(1e-2), capturable=capturable)
    for i in range(7):
        grad = torch.randn(5)
        p.grad = grad.clone()
        ours.found_inf = torch.tensor(float(i in (0, 4)))  # the first step and a later one are skipped
        ours.step()
        if i not in (0, 4):
            q.grad = grad.clone()
            stock.step()
        assert torch.equal(p, q), i
    assert float(ours.state[p]["step"]) == float(stock.state[q]["step"]) == 5


# ------------------------------------------------------------------------------------------ build_trainer
def _cfg(tmp_path: Path, *overrides: str):
    """tests/test_trainer.py's small CPU run (2 epochs of 48-sample minibatches over 8-step rollouts, 4 iterations)
    with loss=pqn and epsilon annealed over half of it; per-step observations, the frames clock and the paper's
    lambda, epsilon floor and unnormalised inputs and values (the known answers below are computed by hand from
    those) unless ``overrides`` set them."""
    pinned = ("loss.hold_observation=false", "loss.epsilon_clock=frames", "loss.lmbda=0.5", "loss.end_epsilon=0.005",
              "loss.normalize_input=false", "loss.normalize_value=false")
    defaults = [d for d in pinned if not any(o.startswith(d.split("=")[0] + "=") for o in overrides)]
    return trainer_cfg(tmp_path, "loss=pqn", "loss.exploration_fraction=0.5", *defaults, *overrides)


def test_pqn_configs_compose_with_the_measured_recipe_and_the_paper_row() -> None:
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        mt10 = compose("config", overrides=["env=mt10_rand", "loss=pqn"])
        small = compose("config", overrides=["env=cpu_small", "loss=pqn"])
    paper = compose_row("efficiency", "mt10_rand_pqn")
    # env=mt10_rand loss=pqn: the measured recipe (docs/results/off_policy_mt10.md "Ninth runs")
    lc = mt10.loss
    assert (mt10.env.num_envs, lc.horizon, lc.epochs, lc.minibatch_size, mt10.max_iterations) == (24576, 16, 8, 32768,
                                                                                                   1200)
    assert mt10.env.num_envs * lc.horizon * mt10.max_iterations == 471_859_200
    assert (lc.lr, lc.max_grad_norm, lc.gamma, lc.lmbda, lc.bins_per_dim) == (3e-4, 10.0, 0.95, 0.9, 3)
    assert (lc.start_epsilon, lc.end_epsilon, lc.exploration_fraction, lc.anneal_lr) == (1.0, 0.05, 0.1, True)
    assert (lc.hold_observation, lc.epsilon_clock, lc.normalize_input, lc.normalize_value) == (False, "frames", True,
                                                                                               True)
    assert dict(mt10.env.overrides) == {"reward_version": "paper", "compile_stages": "auto", "group_models": False}
    # the paper's row (appendix "MT-PQN in MT10" + MTBench's code): every setting explicit, none from the recipe
    pl = paper.loss
    assert (paper.env.num_envs, pl.horizon, pl.epochs, pl.minibatch_size, paper.total_frames) == (8192, 16, 8, 32768,
                                                                                                  6_553_600_000)
    assert (pl.lr, pl.max_grad_norm, pl.gamma, pl.lmbda, pl.bins_per_dim) == (3e-4, 10.0, 0.99, 0.5, 3)
    assert (pl.start_epsilon, pl.end_epsilon, pl.exploration_fraction, pl.anneal_lr) == (1.0, 0.005, 0.005, True)
    assert (pl.hold_observation, pl.epsilon_clock, pl.normalize_input, pl.normalize_value) == (True, "mtbench", False,
                                                                                               False)
    assert dict(paper.env.overrides) == {"reward_version": "paper", "episode_length": 500, "action_scale": 0.005,
                                         "compile_stages": "auto", "group_models": False}
    assert paper.env.num_envs * pl.horizon // pl.minibatch_size == 4
    assert (small.loss.hold_observation, small.loss.epsilon_clock) == (False, "frames")
    assert small.env.num_envs * small.loss.horizon % small.loss.minibatch_size == 0 and small.max_iterations == 200
    # the measured CPU preset (docs/pqn.md): 32 worlds per task x 8 steps, gamma 0.95, per-task input and value
    # normalisation
    sl = small.loss
    assert (small.env.num_envs, sl.horizon, sl.minibatch_size, sl.epochs) == (96, 8, 192, 8)
    assert (sl.gamma, sl.lr, sl.lmbda, sl.end_epsilon, sl.exploration_fraction, sl.normalize_input,
            sl.normalize_value) == (0.95, 3e-3, 0.9, 0.05, 0.1, True, True)


def test_trainer_builds_the_q_policy_radam_and_schedules(tmp_path: Path) -> None:
    trainer = build_trainer(_cfg(tmp_path, "loss.lr=1e-3"), env=_env())
    assert type(trainer.env.action_spec) is Categorical and trainer.env.action_spec.n == 3
    assert isinstance(trainer.loss, MTPQNLoss) and isinstance(trainer.loss.value_estimator, PengQLambda)
    assert isinstance(trainer.optimizer, RAdam)
    assert {id(p) for p in trainer.policy.parameters()} == {id(p) for p in trainer.loss.parameters()}
    names = [h.name for h in trainer.hooks]
    assert names[:3] == ["nonfinite_guard", "epsilon_schedule", "lr_decay"]
    history = trainer.train()
    last = history[-1]
    for key in ("loss/qvalue", "train/q_value", "train/target_value", "train/td_error", "train/epsilon", "train/lr"):
        assert math.isfinite(last[key]), key
    # epsilon annealed over half of the 4 x 96 frames: 1 -> 0.005 at frame 192, the last step is past it
    assert [round(h["train/epsilon"], 6) for h in history] == [
        round(linear_epsilon(96 * i + 12 * 7, 1.0, 0.005, 192), 6) for i in range(4)]
    assert last["train/lr"] == pytest.approx(1e-3 * (1 - 3 / 4))


def test_trainer_anneals_epsilon_on_the_mtbench_clock(tmp_path: Path) -> None:
    trainer = build_trainer(_cfg(tmp_path, "loss.epsilon_clock=mtbench"), env=_env())
    assert trainer.get_hook(EpsilonSchedule).clock == "mtbench"
    history = trainer.train()
    # the rate of the last step (step 7) of iteration i: t = 12 * (i + 7 + 1) against 0.5 * 4 * 96 = 192
    assert [round(h["train/epsilon"], 6) for h in history] == [
        round(linear_epsilon(12 * (i + 8), 1.0, 0.005, 192), 6) for i in range(4)]


def _hand_peng_q_lambda(reward: torch.Tensor, boot_next: torch.Tensor, boot_self: torch.Tensor, done: torch.Tensor,
                        truncated: torch.Tensor, gamma: float, lmbda: float) -> torch.Tensor:
    """Peng's Q(lambda) of a ``[N, T]`` rollout written out per world and step: ``boot_next[:, t]`` is the value of
    the state after step t, used unless the step is truncated (then ``boot_self[:, t]``, the value of the step's own
    input) or done; the trace is cut at done steps."""
    n, t_max = reward.shape
    out = torch.zeros(n, t_max)
    for i in range(n):
        for t in reversed(range(t_max)):
            if done[i, t]:
                out[i, t] = reward[i, t] + gamma * (boot_self[i, t] if truncated[i, t] else 0.0)
            elif t == t_max - 1:
                out[i, t] = reward[i, t] + gamma * boot_next[i, t]
            else:
                out[i, t] = reward[i, t] + gamma * (lmbda * out[i, t + 1] + (1 - lmbda) * boot_next[i, t])
    return out


def test_hold_observation_acts_on_and_stores_the_first_observation_of_the_rollout(tmp_path: Path) -> None:
    """``loss.hold_observation`` (MTBench's rollout loop, which never refreshes its observation): every step of a
    rollout acts on, and stores, the rollout's first observation -- also after an episode end inside it --; the env
    and the ``("next", ...)`` entries keep the true observations, so the next rollout starts from the true current
    one; Peng's Q(lambda) bootstraps ``V(o_0)`` inside the window and ``V`` of the true last next observation at its
    end (MTBench's ``values[t + 1]`` and ``next_values``)."""
    trainer = build_trainer(_cfg(tmp_path, "loss.hold_observation=true", "loss.gamma=0.9"), env=_env())
    assert trainer.rollout.hold_keys == ["observation", "task_id"]
    trainer.policy[-1].eps.fill_(0.0)  # greedy (collect() without the trainer's hooks keeps it there)
    first = trainer.rollout.collect().clone()
    second = trainer.rollout.collect().clone()
    obs, nxt = first["observation"], first["next", "observation"]
    done, truncated = first["next", "done"][..., 0], first["next", "truncated"][..., 0]
    assert done[:, :-1].any(-1).all()  # every world ends an episode inside the window (6-step episodes, T = 8)
    assert torch.equal(obs, obs[:, :1].expand_as(obs))  # o_0 at every step
    assert not torch.equal(nxt[:, 0], obs[:, 0])  # the true next observations
    keep = ~done[:, -1]
    assert torch.equal(second["observation"][keep, 0], nxt[keep, -1])  # the carry kept the true observation
    q = trainer.policy[0]
    with torch.no_grad():
        values0 = q(first[:, 0].select("observation", "task_id").clone())["action_value"]
        last = first[:, -1].select("task_id").clone().set("observation", nxt[:, -1].nan_to_num())
        value_last = greedy_value(q(last)["action_value"])
    assert torch.equal(first["action"], values0.argmax(-1)[:, None].expand_as(first["action"]))  # held greedy action
    v0 = greedy_value(values0)[:, None].expand_as(done)
    boot_next = torch.cat([v0[:, 1:], value_last[:, None]], 1)
    expected = _hand_peng_q_lambda(first["next", "reward"][..., 0], boot_next, v0, done, truncated, 0.9, 0.5)
    torch.testing.assert_close(trainer.advantage(first)["value_target"][..., 0], expected)


def test_hold_period_takes_the_observation_afresh_every_k_steps(tmp_path: Path) -> None:
    """``loss.hold_period=3`` with 8-step rollouts: steps 0-2 act on, and store, the observation of step 0, steps 3-5
    that of step 3 (the true current one then), steps 6-7 that of step 6; the greedy action follows the held
    observation."""
    trainer = build_trainer(_cfg(tmp_path, "loss.hold_observation=true", "loss.hold_period=3"), env=_env())
    assert trainer.rollout.hold_period == 3
    trainer.policy[-1].eps.fill_(0.0)
    first = trainer.rollout.collect().clone()
    obs, nxt, done = first["observation"], first["next", "observation"], first["next", "done"][..., 0]
    for t in range(8):
        assert torch.equal(obs[:, t], obs[:, 3 * (t // 3)]), t
    for start in (3, 6):  # a new hold: the true observation after step start - 1 (or the reset one after a done)
        keep = ~done[:, start - 1]
        assert keep.any() and torch.equal(obs[keep, start], nxt[keep, start - 1])
        assert not torch.equal(obs[:, start], obs[:, start - 1])
    with torch.no_grad():
        greedy = trainer.policy[0](first.select("observation", "task_id").clone())["action_value"].argmax(-1)
    assert torch.equal(first["action"], greedy)


def test_per_step_observation_is_the_default(tmp_path: Path) -> None:
    """Without ``hold_observation`` every step acts on, and stores, its own observation, and the targets bootstrap
    ``V(s_{t+1})``."""
    trainer = build_trainer(_cfg(tmp_path, "loss.gamma=0.9"), env=_env())
    assert trainer.rollout.hold_keys == []
    trainer.policy[-1].eps.fill_(0.0)
    first = trainer.rollout.collect().clone()
    obs, nxt = first["observation"], first["next", "observation"]
    done, truncated = first["next", "done"][..., 0], first["next", "truncated"][..., 0]
    assert torch.equal(obs[:, 1:][~done[:, :-1]], nxt[:, :-1][~done[:, :-1]])
    q = trainer.policy[0]
    with torch.no_grad():
        values = q(first.select("observation", "task_id").clone())["action_value"]
        last = first[:, -1].select("task_id").clone().set("observation", nxt[:, -1].nan_to_num())
        value_last = greedy_value(q(last)["action_value"])
    assert torch.equal(first["action"], values.argmax(-1))
    v = greedy_value(values)
    boot_next = torch.cat([v[:, 1:], value_last[:, None]], 1)
    expected = _hand_peng_q_lambda(first["next", "reward"][..., 0], boot_next, v, done, truncated, 0.9, 0.5)
    torch.testing.assert_close(trainer.advantage(first)["value_target"][..., 0], expected)


class StopAt(TrainerHook):
    """Sends this process SIGINT after env step ``step`` of iteration ``iteration + 1``."""

    name = "stop_at"

    def __init__(self, iteration: int, step: int) -> None:
        self.iteration, self.step = iteration, step

    def on_rollout_step(self, trainer: Any, step: int, horizon: int) -> None:
        if trainer.iteration == self.iteration and step == self.step:
            os.kill(os.getpid(), signal.SIGINT)


@pytest.mark.parametrize("mtbench", [(), ("loss.hold_observation=true", "loss.epsilon_clock=mtbench"),
                                     ("loss.hold_observation=true", "loss.hold_period=2"),
                                     ("loss.normalize_value=true",)])
def test_resume_is_exact_between_iterations_and_inside_a_rollout(tmp_path: Path, mtbench: tuple[str, ...]) -> None:
    """Also with MTBench's held observation (restored from the interrupted rollout's first step) and epsilon clock
    (inside a rollout only: the part the held observation changes)."""
    def cfg(*overrides: str):
        return _cfg(tmp_path, *mtbench, *overrides)

    full = build_trainer(cfg("checkpoint.every=2", f"checkpoint.dir={tmp_path / 'full'}"), env=_env())
    full_history = full.train()
    if "loss.normalize_value=true" in mtbench:  # the per-task value statistics are part of the resumed state
        assert float(full.loss.value_estimator.value_norm.count.min()) > 0
    if not mtbench:
        resumed = build_trainer(cfg(f"resume={tmp_path / 'full' / 'ckpt_000002.pt'}"), env=_env())
        assert resumed.get_hook(EpsilonSchedule).epsilon == full_history[1]["train/epsilon"]
        for a, b in zip(full_history[2:], resumed.train(), strict=True):
            assert_same_metrics(a, b)
        for (name, p), q in zip(full.loss.named_parameters(), resumed.loss.parameters(), strict=True):
            assert torch.equal(p, q), name
        assert torch.equal(full.optimizer.param_groups[0]["lr"], resumed.optimizer.param_groups[0]["lr"])

    stopped = build_trainer(cfg(f"checkpoint.dir={tmp_path / 'stop'}"), env=_env())
    stopped.add_hook(StopAt(iteration=1, step=3))
    assert len(stopped.train()) == 1 and stopped.rollout.steps_done == 3
    ckpt = tmp_path / "stop" / "ckpt_000001_step0003.pt"
    rest = build_trainer(cfg(f"resume={ckpt}", f"checkpoint.dir={tmp_path / 'stop2'}"), env=_env()).train()
    for a, b in zip(full_history[1:], rest, strict=True):
        assert_same_metrics(a, b)


def test_non_finite_updates_are_skipped_with_radam(tmp_path: Path) -> None:
    trainer = build_trainer(_cfg(tmp_path, "loss.minibatch_size=96"), env=_env(nan_reward_at_step=10))
    trainer.train_iteration()
    before = {k: v.detach().clone() for k, v in trainer.loss.named_parameters()}
    step_before = float(trainer.optimizer.state[next(iter(trainer.loss.parameters()))]["step"])
    with pytest.warns(RuntimeWarning, match="skipped"):
        metrics = trainer.train_iteration()
    assert metrics["train/skipped_updates"] == 2 and trainer.get_hook(NonFiniteGuard).skipped_total == 2
    for key, value in trainer.loss.named_parameters():
        assert torch.equal(value, before[key]), key
    assert float(trainer.optimizer.state[next(iter(trainer.loss.parameters()))]["step"]) == step_before
    trainer.train_iteration()
    assert any(not torch.equal(v, before[k]) for k, v in trainer.loss.named_parameters())


def test_pcgrad_wraps_the_pqn_loss(tmp_path: Path) -> None:
    torch.manual_seed(0)
    q = make_q_network("mlp", obs_dim=6, action_dim=3, bins=3, num_tasks=1, hidden=[16])
    loss = MTPQNLoss(q)
    batch = TensorDict({"observation": torch.randn(12, 6), "task_id": torch.zeros(12, dtype=torch.long),
                        "action": torch.randint(0, 3, (12, 3)), "value_target": torch.randn(12, 1)}, [12])
    compute_gradients(loss, batch)
    plain = [p.grad.clone() for p in loss.parameters()]
    loss.zero_grad()
    wrapped = make_gradient_method("pcgrad", loss, 1, critic_keys=["loss_qvalue"])  # the Q network is the critic
    compute_gradients(wrapped, batch)
    for p, g in zip(loss.parameters(), plain, strict=True):  # one task: PCGrad's mean projected gradient is the plain gradient
        torch.testing.assert_close(p.grad, g)
    loss.zero_grad()
    found = make_gradient_method("pcgrad", loss, 1)  # no critic_keys: found from the parameter groups
    compute_gradients(found, batch)
    for p, g in zip(loss.parameters(), plain, strict=True):
        torch.testing.assert_close(p.grad, g)
    assert found._group_term_names("critic", found._task_losses(batch)) == ["loss_qvalue"]
    trainer = build_trainer(_cfg(tmp_path, "grad=pcgrad", "max_iterations=1"), env=_env())
    assert trainer.update_module is not trainer.loss
    assert math.isfinite(trainer.train_iteration()["loss/qvalue"])


# ------------------------------------------------------------------------------------------ CUDA-graphed update
def _rollout_batch(trainer: Any) -> TensorDict:
    """One collected rollout with its Peng's Q(lambda) targets, flat (what ``Trainer.update`` passes on)."""
    data, _ = trainer.collect()
    return trainer.advantage(data).exclude("next").reshape(-1)


@pytest.mark.parametrize(("method", "foreach"), [("none", False), ("none", True), ("pcgrad", True)])
def test_graphed_pqn_step_has_no_host_sync(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, method: str,
                                           foreach: bool) -> None:
    """The whole update the CUDA graph captures for ``loss=pqn`` -- the static-buffer gather, ``MTPQNLoss`` (the
    Peng's Q(lambda) targets are computed before, per rollout), the gradient method's backward, the global clip,
    the hooks (``NonFiniteGuard`` setting ``found_inf`` on the device; the learning-rate decay and the epsilon
    schedule run between updates and change their tensors in place) and the ``capturable=True`` RAdam step that
    honours ``found_inf`` (single-tensor and foreach, the latter the CUDA default) -- converts no tensor to Python
    and uses no data-dependent shape, on the CPU with the conversions patched to raise."""
    import mtbench.objectives.task_wrapper as tw

    trainer = build_trainer(_cfg(tmp_path, f"grad={method}"), env=_env())
    flat = _rollout_batch(trainer)
    allow_capturable_on_cpu(monkeypatch)
    params = [p for p in trainer.loss.parameters() if p.requires_grad]
    lr = torch.tensor(float(trainer.config.loss.lr))
    trainer.optimizer = RAdam(params, lr=lr, betas=(0.9, 0.999), eps=1e-8, capturable=True, foreach=foreach)
    updater = MinibatchUpdate(trainer.update_module, trainer.optimizer, max_grad_norm=trainer.updater.max_grad_norm,
                              call_hooks=trainer._call, graph=True, device="cpu")
    assert updater.graph and not updater._stage.enabled  # the graphed code path, run eagerly on the CPU
    updater.epochs(flat, 1, trainer.minibatch_size)  # warm-up (lazy optimizer state), as before a capture
    monkeypatch.setattr(tw, "check_task_ids", lambda *a, **k: None)  # CPU-only id check (skipped on CUDA)
    trainer.iteration = 1
    trainer._call("on_iteration_start")  # epsilon and learning rate: in place, outside the update
    assert trainer.optimizer.param_groups[0]["lr"] is lr and float(lr) < float(trainer.config.loss.lr)

    def state() -> tuple[list[torch.Tensor], list[torch.Tensor]]:
        return ([p.detach().clone() for p in params],
                [t.clone() for p in params for t in trainer.optimizer.state[p].values()])

    def same(a: list[torch.Tensor], b: list[torch.Tensor]) -> bool:
        return all(torch.equal(x, y) for x, y in zip(a, b, strict=True))

    forbid_host_sync(monkeypatch)
    before = state()
    means, count = updater.epochs(flat, 2, trainer.minibatch_size)
    moved = state()
    lr.fill_(0.0)  # what a replay reads: the tensor's current value (a zero rate moves no parameter)
    updater.epochs(flat, 1, trainer.minibatch_size)
    unmoved = state()
    bad = flat.clone()
    bad["value_target"].fill_(float("nan"))  # every update skipped on the device: nothing moves, not even the step
    lr.fill_(1e-3)
    bad_means, _ = updater.epochs(bad, 1, trainer.minibatch_size)
    skipped = state()
    monkeypatch.undo()
    assert count == 2 * trainer.num_minibatches and torch.isfinite(means["loss_qvalue"])
    assert not same(before[0], moved[0]) and not same(before[1], moved[1])
    assert same(moved[0], unmoved[0]) and not same(moved[1], unmoved[1])  # lr 0: parameters stay, moments move
    assert float(bad_means["skipped"]) == 1.0
    assert same(unmoved[0], skipped[0]) and same(unmoved[1], skipped[1])


def test_graphed_pqn_update_path_equals_the_eager_one(tmp_path: Path) -> None:
    """``MinibatchUpdate(graph=True)``'s code path (minibatches gathered into static buffers, the step of the
    graph) gives exactly the parameters, RAdam state and metrics of the eager path from the same state and seed
    (on the CPU nothing is captured; benchmarks/update_check.py --loss pqn compares the replayed graph on a GPU)."""
    trainer = build_trainer(_cfg(tmp_path), env=_env())
    flat = _rollout_batch(trainer)
    start = (copy.deepcopy(trainer.loss.state_dict()), copy.deepcopy(trainer.optimizer.state_dict()))
    results = []
    for graph in (True, False):
        trainer.loss.load_state_dict(start[0])
        trainer.optimizer.load_state_dict(copy.deepcopy(start[1]))
        torch.manual_seed(3)
        updater = MinibatchUpdate(trainer.update_module, trainer.optimizer, max_grad_norm=10.0,
                                  call_hooks=trainer._call, graph=graph, device="cpu")
        means, _ = updater.epochs(flat, 2, trainer.minibatch_size)
        results.append(({k: v.clone() for k, v in trainer.loss.state_dict().items()},
                        copy.deepcopy(trainer.optimizer.state_dict()["state"]), means))
    (params_g, opt_g, means_g), (params_e, opt_e, means_e) = results
    assert not all(torch.equal(params_g[k], v) for k, v in start[0].items())
    for key, value in params_e.items():
        assert torch.equal(params_g[key], value), key
    for index, saved in opt_e.items():
        for key, value in saved.items():
            assert torch.equal(opt_g[index][key], value), (index, key)
    assert means_g.keys() == means_e.keys() and all(torch.equal(means_g[k], means_e[k]) for k in means_e)


def test_cudagraph_update_resolves_for_pqn(tmp_path: Path) -> None:
    from mtbench.trainer.builder import graph_safe_update, resolve_graph_update

    trainer = build_trainer(_cfg(tmp_path), env=_env())  # auto on the CPU: off
    assert not trainer.updater.graph
    assert graph_safe_update(trainer.update_module, trainer.loss)
    # auto graphs PQN's update on CUDA (update_check.py --loss pqn compared it with the eager one on an H200)
    assert resolve_graph_update("auto", torch.device("cuda"), graph_safe_update(trainer.update_module, trainer.loss))
    assert not resolve_graph_update(False, torch.device("cuda"), True)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("loss.bins_per_dim=1", "loss.bins_per_dim must be an integer >= 2"),
        ("loss.lmbda=1.5", r"loss.lmbda must be a number in \[0.0, 1.0\]; got 1.5"),
        ("loss.gamma=0", r"loss.gamma must be a number in \(0.0, 1.0\]; got 0"),
        ("loss.end_epsilon=0.5", "loss.end_epsilon=0.5 must be <= loss.start_epsilon=0.4"),
        ("loss.exploration_fraction=0", r"loss.exploration_fraction must be a number in \(0.0, 1.0\]"),
        ("loss.anneal_lr=maybe", "loss.anneal_lr must be true or false"),
        ("loss.epsilon_clock=steps", r"unknown loss.epsilon_clock 'steps'; valid choices: \['frames', 'mtbench'\]"),
        ("loss.hold_observation=maybe", "loss.hold_observation must be true or false"),
        ("loss.normalize_value=maybe", "loss.normalize_value must be true or false"),
        ("loss.hold_period=9", r"loss.hold_period must be an integer in \[1, loss.horizon=8\] or null \(the whole "
                               r"rollout\); got 9"),
        ("loss.hold_period=0", r"loss.hold_period must be an integer in \[1, loss.horizon=8\]"),
        ("loss.loss_function=huber", r"unknown loss.loss_function 'huber'; valid choices: \['l2', 'l1', 'smooth_l1"),
        ("loss.name=dqn", r"unknown loss.name 'dqn'; valid choices: \[.*'pqn'.*\]"),
        ("cudagraph_update=true", r"cudagraph_update=true needs a CUDA device \(device=cpu\)"),
    ],
)
def test_config_errors(tmp_path: Path, override: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        build_trainer(_cfg(tmp_path, "loss.start_epsilon=0.4", override), env=_env())


def test_env_bins_must_match_the_loss(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="5 bins, loss.bins_per_dim=3"):
        build_trainer(_cfg(tmp_path), env=_discrete_synthetic(5, action_dim=2))


def test_pretrained_log_std_with_a_q_policy_is_one_clear_error(tmp_path: Path) -> None:
    from mtbench.trainer.pretraining import load_pretrained

    trainer = build_trainer(_cfg(tmp_path), env=_env())
    path = trainer.save(tmp_path / "q.pt")
    load_pretrained(trainer, path)  # the Q-network's own weights load
    with pytest.raises(ValueError, match=r"^pretrained_log_std=0.0 needs a policy with a state-independent log-std "
                                         r"\(loss=ppo\|grpo\); this run's actor has none \(loss=pqn\)"):
        load_pretrained(trainer, path, log_std=0.0)
    from mtbench.trainer.config import check_config

    with pytest.raises(ValueError, match=r"^pretrained_log_std applies to loss=ppo\|grpo .*loss=pqn has none"):
        check_config(_cfg(tmp_path, "+pretrained_log_std=0.0"))
