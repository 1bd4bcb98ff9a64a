"""rl_games' KL-adaptive learning rate, ``schedule_type: standard`` (``loss.lr_schedule_type=standard``): the lr adapts
once per epoch on the epoch's mean KL, and each minibatch's KL is measured against the policy's distribution on it one
epoch earlier (rl_games ``update_mu_sigma``), the first epoch's against the behaviour policy. Known answers on a
linear "policy" whose distribution is ``loc = x @ W``, through ``MinibatchUpdate`` (eager and the graph code path),
the ``AdaptiveLR`` hook and the trainer built from the config."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir
from tensordict import TensorDict, TensorDictBase
from torch import nn

from envs_for_tests import SyntheticMTEnv
from mtbench.trainer import build_trainer
from mtbench.trainer.hooks import AdaptiveLR, TrainerHook
from mtbench.trainer.update import MinibatchUpdate

ROOT = Path(__file__).resolve().parents[1]


class LinearPolicyLoss(nn.Module):
    """``loc = x @ W``; loss ``sum(loc)``; metric ``kl`` = mean squared distance of ``loc`` to the batch's ``loc``
    (a stand-in for the Gaussian KL: what matters here is which reference it is measured against)."""

    def __init__(self) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.linspace(-1.0, 1.0, 6).reshape(3, 2))

    def loc(self, td: TensorDictBase) -> torch.Tensor:
        return td["x"] @ self.weight

    def forward(self, td: TensorDictBase) -> TensorDict:
        loc = self.loc(td)
        kl = ((loc.detach() - td["loc"]) ** 2).mean()
        return TensorDict({"loss_objective": (loc * td["x"][:, :2]).sum(), "kl": kl}, batch_size=[])


class Recorder:
    """Hook caller: the weights before every step, each update's ``kl``, each epoch's mean ``kl``."""

    def __init__(self) -> None:
        self.weights: list[torch.Tensor] = []
        self.kls: list[float] = []
        self.epoch_kls: list[float] = []

    def __call__(self, point: str, metrics) -> None:
        if point == "before_optimizer_step":
            self.weights.append(self.module.weight.detach().clone())
        elif point == "on_update":
            self.kls.append(float(metrics["kl"]))
        elif point == "on_epoch_end":
            self.epoch_kls.append(float(metrics["kl"]))


def _run(graph: bool, epochs: int, minibatch_size: int, reference: bool = True):
    torch.manual_seed(0)
    module = LinearPolicyLoss()
    x = torch.randn(8, 3)
    batch = TensorDict({"x": x, "loc": torch.zeros(8, 2)}, batch_size=[8])
    rec = Recorder()
    rec.module = module
    opt = torch.optim.SGD(module.parameters(), lr=0.1)
    kl_reference = (lambda mb: {"loc": module.loc(mb)}) if reference else None
    update = MinibatchUpdate(module, opt, max_grad_norm=None, call_hooks=rec, graph=graph, kl_reference=kl_reference)
    update.epochs(batch, epochs, minibatch_size)
    return module, x, batch, rec


@pytest.mark.parametrize("graph", [False, True])
def test_each_epoch_measures_kl_against_the_policy_one_epoch_earlier(graph: bool) -> None:
    """One minibatch per epoch: epoch 1 against the behaviour ``loc`` (zeros here), epoch e against ``x @ W_{e-1}``
    (the weights before the step of epoch e-1); afterwards the batch holds ``x @ W_last`` (before the last step)."""
    module, x, batch, rec = _run(graph, epochs=3, minibatch_size=8)
    w = rec.weights  # W_0, W_1, W_2: before each of the three steps
    assert len(w) == 3 and not torch.equal(w[0], w[1])
    expected = [((x @ w[0]) ** 2).mean(), ((x @ w[1] - x @ w[0]) ** 2).mean(), ((x @ w[2] - x @ w[1]) ** 2).mean()]
    assert rec.kls == pytest.approx([float(e) for e in expected], rel=1e-5)
    assert rec.epoch_kls == pytest.approx(rec.kls, rel=1e-6)  # one update per epoch: the epoch mean is its KL
    torch.testing.assert_close(batch["loc"], x @ w[2])


@pytest.mark.parametrize("graph", [False, True])
def test_rows_get_the_distribution_of_their_own_minibatch(graph: bool) -> None:
    """Two minibatches in one epoch: every row holds ``x @ W`` of the update that took it (4 rows each); the epoch's
    mean KL is the mean of its two updates'."""
    _, x, batch, rec = _run(graph, epochs=1, minibatch_size=4)
    first = torch.isclose(batch["loc"], x @ rec.weights[0]).all(-1)
    second = torch.isclose(batch["loc"], x @ rec.weights[1]).all(-1)
    assert int(first.sum()) == 4 and int(second.sum()) == 4 and not (first & second).any()
    assert rec.epoch_kls == pytest.approx([sum(rec.kls) / 2], rel=1e-6)


def test_without_a_reference_the_batch_is_unchanged() -> None:
    _, x, batch, rec = _run(False, epochs=3, minibatch_size=8, reference=False)
    assert torch.equal(batch["loc"], torch.zeros(8, 2))
    assert rec.kls == pytest.approx([float(((x @ w) ** 2).mean()) for w in rec.weights], rel=1e-5)


def test_graph_path_equals_the_eager_one() -> None:
    _, _, eager, rec_e = _run(False, epochs=3, minibatch_size=4)
    _, _, graphed, rec_g = _run(True, epochs=3, minibatch_size=4)
    torch.testing.assert_close(graphed["loc"], eager["loc"], rtol=0, atol=0)
    assert rec_g.kls == rec_e.kls and rec_g.epoch_kls == rec_e.epoch_kls


class _Opt:
    def __init__(self, lr: float) -> None:
        self.optimizer = torch.optim.SGD([nn.Parameter(torch.zeros(1))], lr=lr)


@pytest.mark.parametrize(("kl", "factor"), [(0.02, 1 / 1.5), (0.001, 1.5), (0.008, 1.0), (float("nan"), 1.0)])
def test_adaptive_lr_per_epoch_known_answers(kl: float, factor: float) -> None:
    """rl_games AdaptiveScheduler with threshold 0.008: down by 1.5 above 0.016, up below 0.004, else (and for a
    non-finite KL) unchanged; with ``period="epoch"`` only at the end of an epoch, never after an update."""
    hook, trainer = AdaptiveLR(0.008, period="epoch"), _Opt(1e-3)
    hook.on_train_start(trainer)
    hook.on_update(trainer, TensorDict({"kl": torch.tensor(1.0)}, batch_size=[]))  # ignored in epoch mode
    assert float(trainer.optimizer.param_groups[0]["lr"]) == pytest.approx(1e-3)
    hook.on_epoch_end(trainer, {"kl": torch.tensor(kl)})
    assert float(trainer.optimizer.param_groups[0]["lr"]) == pytest.approx(1e-3 * factor)
    with pytest.raises(ValueError, match=r"unknown AdaptiveLR period 'iteration'; valid choices: \['minibatch', 'epoch'\]"):
        AdaptiveLR(period="iteration")


def _cfg(tmp_path: Path, *overrides: str):
    base = ["device=cpu", "arch.kwargs.hidden=[16]", "loss.horizon=8", "loss.epochs=3", "loss.minibatch_size=48",
            "max_iterations=1", f"checkpoint.dir={tmp_path / 'ckpt'}", "checkpoint.every=0", "logging.progress=none",
            f"logging.log_dir={tmp_path / 'runs'}", "loss.lr_schedule=adaptive"]
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        return compose("config", overrides=[*base, *overrides])


class KLRecorder(TrainerHook):
    name = "kl_recorder"

    def __init__(self) -> None:
        self.kls: list[float] = []

    def on_update(self, trainer, metrics) -> None:
        self.kls.append(float(metrics["kl"]))


def test_ppo_run_measures_later_epochs_against_the_previous_one(tmp_path: Path) -> None:
    """MT-PPO on the synthetic env, 3 epochs x 2 minibatches, the lr held fixed (min_lr = max_lr) so that both
    schedule types make the same updates: the first epoch's KLs are the same (against the behaviour policy; the
    KL's floor at the first update), the later ones with ``standard`` (one epoch of change) are smaller than with ``minibatch``
    (the distance to the behaviour policy)."""
    kls: dict[str, list[float]] = {}
    for kind in ("standard", "minibatch"):
        trainer = build_trainer(_cfg(tmp_path / kind, f"loss.lr_schedule_type={kind}", "loss.min_lr=5e-4",
                                     "loss.max_lr=5e-4"), env=SyntheticMTEnv([4, 4, 4], max_episode_steps=6, seed=0))
        recorder = KLRecorder()
        trainer.add_hook(recorder)
        trainer.train_iteration()
        kls[kind] = recorder.kls
    standard, minibatch = kls["standard"], kls["minibatch"]
    assert len(standard) == len(minibatch) == 6
    floor = standard[0]  # rl_games' KL of two equal Gaussians: sum over dimensions of log(1 + 1e-5)
    assert floor == pytest.approx(minibatch[0], rel=1e-6) and floor < 1e-4
    assert standard[1] == pytest.approx(minibatch[1], rel=1e-4) and standard[1] > floor
    assert all(floor < s < m for s, m in zip(standard[2:], minibatch[2:])), (standard, minibatch)
