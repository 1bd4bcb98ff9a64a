"""Evaluation of an MT-PQN checkpoint through the entry points of examples/eval.py.

A tiny ``loss=pqn`` run on the CPU (``env=cpu_small``: 3 Meta-World tasks, 2 worlds each, 30-step episodes, a small
MOORE Q network, per-task input normalisation, 2 iterations) provides the checkpoint. The evaluation env is the
run's (continuous actions): the greedy action of every dimension is the arg-max bin of the Q network, mapped to
``{-1, 0, +1}``.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Categorical, MultiCategorical, Unbounded

from cpu_runs import train_on_cpu
from mtbench.evaluation import EvalArgumentError, evaluate, load_policy, main, make_eval_env, parse_args
from mtbench.evaluation.policy import read_checkpoint
from mtbench.evaluation.q_policy import EvalQPolicy
from mtbench.trainer import Trainer
from mtbench.trainer.trainer import observation_norm

TASKS = ["reach", "drawer_close", "button_press_topdown"]
EPISODE_STEPS = 30
NUM_ENVS = 6
OBS_DIM = 39 + len(TASKS)


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Trainer, Path]:
    root = tmp_path_factory.mktemp("pqn_eval_run")
    overrides = [
        "device=cpu", "env=cpu_small", "loss=pqn", f"env.num_envs={NUM_ENVS}",
        f"+env.overrides.episode_length={EPISODE_STEPS}", "arch=moore", "arch.kwargs.num_experts=2",
        "arch.kwargs.num_layers=2", "arch.kwargs.hidden_dim=32", "arch.kwargs.task_encoder=[16]", "loss.horizon=8",
        "loss.epochs=2", "loss.minibatch_size=24", "loss.normalize_input=true", "max_iterations=2",
        "logging.progress=none", "checkpoint.every=0", f"checkpoint.dir={root / 'ckpt'}",
    ]
    trainer, _ = train_on_cpu(overrides)
    return trainer, root / "ckpt" / "final.pt"


def _observations(seed: int = 0) -> TensorDict:
    """Observations of the 6 worlds: random states (scaled like the env's) and the task one-hots."""
    gen = torch.Generator().manual_seed(seed)
    task_id = torch.tensor([0, 0, 1, 1, 2, 2])
    state = torch.randn(NUM_ENVS, 39, generator=gen) * 0.3
    obs = torch.cat([state, torch.nn.functional.one_hot(task_id, len(TASKS)).float()], dim=-1)
    return TensorDict({"observation": obs, "task_id": task_id}, batch_size=[NUM_ENVS])


def _trained_greedy_bins(trainer: Trainer, td: TensorDict) -> torch.Tensor:
    """The known answer: arg-max bin per dimension of the trained Q network on the observation normalised with the
    run's per-task statistics (``stats.normalize`` does not update them; the task one-hot stays as it is)."""
    stats = observation_norm(trainer.env).stats
    state, one_hot = td["observation"].split([39, len(TASKS)], dim=-1)
    obs = torch.cat([stats.normalize(state, td["task_id"]), one_hot], dim=-1)
    with torch.no_grad():
        action_value = trainer.policy[0](TensorDict({"observation": obs, "task_id": td["task_id"]},
                                                    batch_size=td.batch_size))["action_value"]
    assert action_value.shape == (NUM_ENVS, 4, 3)
    return action_value.argmax(-1)


def _spec_env(action_spec) -> SimpleNamespace:
    """What load_policy reads of an env: its sizes and action spec."""
    return SimpleNamespace(num_tasks=len(TASKS), observation_spec={"observation": torch.zeros(NUM_ENVS, OBS_DIM)},
                           action_spec=action_spec)


def test_greedy_eval_actions_are_the_arg_max_bins_of_the_trained_q_network(run) -> None:
    trainer, path = run
    state = read_checkpoint(path)
    env = make_eval_env(state["config"]["env"], NUM_ENVS, torch.device("cpu"), seed=5)  # the run's env: continuous
    try:
        policy = load_policy(state, env, torch.device("cpu"))
        assert isinstance(policy, EvalQPolicy) and policy.obs_norm is not None and policy.bins == 3
        for td in (env.reset(), _observations(0), _observations(1)):
            td = td.select("observation", "task_id")
            raw = td["observation"].clone()
            bins = _trained_greedy_bins(trainer, td)
            action = policy(td, deterministic=True)
            assert action.dtype == torch.float32 and action.shape == (NUM_ENVS, 4)
            assert torch.equal(action, bins.float() - 1.0)  # bin b -> -1 + 2 b / (3 - 1)
            assert torch.equal(td["observation"], raw)  # the input is not normalised in place
        assert len(torch.unique(bins)) > 1  # a non-trivial answer: the Q network prefers different bins
    finally:
        env.close()


def test_eval_on_a_discrete_env_returns_bins_and_refuses_other_bins_counts(run) -> None:
    trainer, path = run
    state = read_checkpoint(path)
    policy = load_policy(state, _spec_env(Categorical(3, shape=(NUM_ENVS, 4))), torch.device("cpu"))
    td = _observations(2)
    action = policy(td, deterministic=True)
    assert action.dtype == torch.int64 and torch.equal(action, _trained_greedy_bins(trainer, td))
    with pytest.raises(EvalArgumentError, match=r"5 bins per dimension, the checkpoint's Q network 3 "
                                                r"\(loss.bins_per_dim=3\)"):
        load_policy(state, _spec_env(Categorical(5, shape=(NUM_ENVS, 4))), torch.device("cpu"))
    for spec in (Unbounded(shape=(NUM_ENVS, 4)), MultiCategorical([3, 3, 3, 3], shape=(NUM_ENVS, 4))):
        with pytest.raises(EvalArgumentError, match="Bounded \\(continuous\\) or Categorical action spec; got "
                                                    f"{type(spec).__name__}"):
            load_policy(state, _spec_env(spec), torch.device("cpu"))
    mlp_state = {**state, "config": {**state["config"], "arch": {"name": "mlp", "kwargs": {"hidden": [8]}}}}
    with pytest.raises(EvalArgumentError, match="Q network does not fit the rebuilt one \\(arch='mlp'\\)"):
        load_policy(mlp_state, _spec_env(Categorical(3, shape=(NUM_ENVS, 4))), torch.device("cpu"))


def test_sampled_eval_is_epsilon_greedy_per_world(run) -> None:
    trainer, path = run
    state = read_checkpoint(path)
    policy = load_policy(state, _spec_env(Categorical(3, shape=(NUM_ENVS, 4))), torch.device("cpu"))
    assert policy.epsilon == pytest.approx(float(state["config"]["loss"]["end_epsilon"])) == pytest.approx(0.05)
    td = _observations(3).expand(700, NUM_ENVS).reshape(-1).clone()  # 700 copies of the 6 worlds
    greedy = policy(td, deterministic=True)
    torch.manual_seed(0)
    policy.epsilon = 0.0
    assert torch.equal(policy(td, deterministic=False), greedy)
    policy.epsilon = 0.5
    differs = (policy(td, deterministic=False) != greedy).any(-1).float().mean()
    # a world explores with probability 0.5 and then draws 4 uniform bins, equal to the greedy ones w.p. 1/81
    assert abs(differs - 0.5 * (1 - 1 / 81)) < 0.03
    policy.epsilon = 1.0
    counts = torch.bincount(policy(td, deterministic=False).reshape(-1), minlength=3).float()
    assert torch.allclose(counts / counts.sum(), torch.full((3,), 1 / 3), atol=0.02)


def test_a_hold_observation_run_holds_the_greedy_action_for_horizon_steps(run) -> None:
    """``loss.hold_observation`` (MTBench's rollouts): the evaluation policy acts as the run's rollouts did, the
    greedy action of every ``loss.horizon``-th call's observation kept in between, and a new hold after ``reset()``
    (which run_episodes calls after every env reset); exploration still draws at every call."""
    trainer, path = run
    state = read_checkpoint(path)
    spec_env = _spec_env(Categorical(3, shape=(NUM_ENVS, 4)))
    assert load_policy(state, spec_env, torch.device("cpu")).hold_steps == 1  # the run's per-step observations
    loss = {**state["config"]["loss"], "hold_observation": True, "horizon": 3}
    policy = load_policy({**state, "config": {**state["config"], "loss": loss}}, spec_env, torch.device("cpu"))
    assert policy.hold_steps == 3
    periodic = {**loss, "horizon": 8, "hold_period": 3}  # loss.hold_period: the hold of the run's rollouts
    assert load_policy({**state, "config": {**state["config"], "loss": periodic}}, spec_env,
                       torch.device("cpu")).hold_steps == 3
    tds = [_observations(seed) for seed in range(8)]
    greedy = [_trained_greedy_bins(trainer, td) for td in tds]
    assert not torch.equal(greedy[0], greedy[1])  # the observations call for different actions
    acted = [policy(td, deterministic=True) for td in tds[:5]]
    for i, action in enumerate(acted):
        assert torch.equal(action, greedy[0 if i < 3 else 3]), i
    policy.reset()
    assert torch.equal(policy(tds[6], deterministic=True), greedy[6])
    assert torch.equal(policy(tds[7], deterministic=True), greedy[6])
    policy.reset()
    policy.epsilon = 1.0
    torch.manual_seed(0)
    sampled = torch.stack([policy(tds[i % 2], deterministic=False) for i in range(3)])
    assert not torch.equal(sampled[1], sampled[2])  # a fresh draw at every call
    with pytest.raises(ValueError, match="hold_steps must be an integer >= 1"):
        EvalQPolicy(policy.q_network, None, 3, 0.0, hold_steps=0)


def test_eval_entry_points_run_a_pqn_checkpoint(run, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, path = run
    out = tmp_path / "main"
    assert main([f"checkpoint={path}", "episodes=2", "device=cpu", f"out={out}", "seed=3"]) == 0
    table = [line for line in capsys.readouterr().out.splitlines() if line.startswith("|")]
    assert len(table) == 2 + len(TASKS) + 1 and [r.split("|")[1].strip() for r in table[2:-1]] == TASKS
    report = json.loads((out / "eval.json").read_text())
    assert report["loss"] == "pqn" and report["arch"] == "moore" and report["episode_steps"] == EPISODE_STEPS
    for mode in ("sampled", "deterministic"):
        for row in report["evaluations"][mode]["per_task"].values():
            assert row["episodes"] == 2 and row["length"] == EPISODE_STEPS and 0.0 <= row["success"] <= 1.0

    def no_exploration(policy: EvalQPolicy) -> None:
        policy.epsilon = 0.0

    args = parse_args([f"checkpoint={path}", "episodes=2", "device=cpu", f"out={tmp_path / 'greedy'}", "seed=3"])
    sampled, deterministic = evaluate(args, policy_hook=no_exploration, logger="none").results
    assert sampled.returns == deterministic.returns and sampled.success == deterministic.success
    greedy = json.loads((out / "eval.json").read_text())["evaluations"]["deterministic"]["per_task"]
    assert [greedy[t]["return"] for t in TASKS] == pytest.approx(deterministic.returns)  # same seed, same episodes
