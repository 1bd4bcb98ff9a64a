"""torchrun: N processes train one run. Two CPU processes (gloo) against one process on the same data: the running
statistics, the per-task advantage standardisation and one whole MT-PPO minibatch update (every gradient method) are
the same; a two-process ``examples/train.py`` run writes one checkpoint per rank and resumes only with two processes;
a two-process MT-SAC run keeps its networks equal; what does not split over processes is one clear error."""

from __future__ import annotations

import functools
import os
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

import pytest
import torch
import torch.multiprocessing as mp
from omegaconf import OmegaConf
from tensordict import TensorDict

from mtbench.objectives import MTPPOLoss, make_gradient_method
from mtbench.objectives.mt_utils import per_task_standardize
from mtbench.trainer.actor_critic import make_actor, make_critic
from mtbench.trainer.checkpoint import load_checkpoint
from mtbench.trainer.ranks import check_distributed, rank_file
from mtbench.trainer.update import MinibatchUpdate
from mtbench.transforms.running_mean_std import PerTaskRunningMeanStd
from mtbench.utils import distributed
from mtbench.utils.distributed import DistributedContext, context_from_environment

ROOT = Path(__file__).resolve().parents[1]
K, STATE, N = 3, 5, 48  # tasks, state features, samples (each of the two ranks holds half)


# ---------------------------------------------------------------------------------------------- helpers
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _worker(rank: int, world: int, port: int, fn: Callable[[int], Any], out: Any) -> None:
    os.environ.update(MASTER_ADDR="127.0.0.1", MASTER_PORT=str(port))
    torch.set_num_threads(1)
    distributed.init_process_group(DistributedContext(rank, world, rank), torch.device("cpu"))
    try:
        out[rank] = fn(rank)
    finally:
        distributed.shutdown()


def run_ranks(fn: Callable[[int], Any], world: int = 2) -> list[Any]:
    """``fn(rank)`` in ``world`` processes joined by a gloo group; their return values, by rank."""
    with mp.Manager() as manager:
        out = manager.dict()
        mp.spawn(_worker, args=(world, _free_port(), fn, out), nprocs=world, join=True)
        return [out[r] for r in range(world)]


def _data(seed: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(seed)
    task_id = torch.arange(K).repeat(N // K)[torch.randperm(N, generator=g)]
    x = torch.randn(N, STATE, generator=g) * (1 + task_id[:, None]) + 3 * task_id[:, None]
    return x, task_id


def _half(t: torch.Tensor, rank: int) -> torch.Tensor:
    return t[rank * (N // 2):(rank + 1) * (N // 2)]


# ---------------------------------------------------------------------------------------------- reductions
def _stats_on_half(rank: int) -> dict[str, torch.Tensor]:
    x, tid = _data()
    stats = PerTaskRunningMeanStd(K, STATE)
    stats.update(_half(x, rank), _half(tid, rank))
    stats.update(_half(x + 1, rank), _half(tid, rank))
    return {k: v.clone() for k, v in stats.state_dict().items()}


def test_running_statistics_of_two_processes_are_those_of_all_their_rows() -> None:
    x, tid = _data()
    single = PerTaskRunningMeanStd(K, STATE)
    single.update(x, tid)
    single.update(x + 1, tid)
    for state in run_ranks(_stats_on_half):
        for key, value in single.state_dict().items():
            torch.testing.assert_close(state[key], value)
    # known answer: the statistics of the 2N rows of each task
    both = torch.cat([x, x + 1]).double()
    tid2 = torch.cat([tid, tid])
    for k in range(K):
        torch.testing.assert_close(single.mean[k], both[tid2 == k].mean(0))
        torch.testing.assert_close(single.var[k], both[tid2 == k].var(0, unbiased=False))


def _standardize_half(rank: int) -> torch.Tensor:
    x, tid = _data()
    return per_task_standardize(_half(x[:, 0], rank), _half(tid, rank), K)


def test_per_task_standardisation_uses_every_process_samples() -> None:
    x, tid = _data()
    single = per_task_standardize(x[:, 0], tid, K)
    torch.testing.assert_close(torch.cat(run_ranks(_standardize_half)), single)


def _episode_stats(rank: int) -> dict[str, torch.Tensor]:
    stats = {"episodes": torch.tensor([1.0, 2.0 + rank]), "max_terrain_level": torch.tensor([3.0 * rank, 1.0])}
    distributed.all_reduce_stats_(stats)
    return stats


def test_episode_statistics_are_summed_and_the_highest_level_maxed() -> None:
    for stats in run_ranks(_episode_stats):
        assert stats["episodes"].tolist() == [2.0, 5.0]
        assert stats["max_terrain_level"].tolist() == [3.0, 1.0]


# ---------------------------------------------------------------------------------------------- one update
def _ppo_step(rows: slice, grad: str = "none") -> dict[str, torch.Tensor]:
    """One MinibatchUpdate step of MT-PPO (per-task advantage standardisation, grad-norm clip on; through the
    gradient method ``grad``) on ``rows`` of a fixed batch; the parameters and scalar metrics afterwards."""
    arch = {"name": "mlp", "kwargs": {"hidden": [16, 16]}}
    torch.manual_seed(0)
    actor = make_actor(arch, obs_dim=STATE + K, action_dim=2, num_tasks=K)
    critic = make_critic(arch, obs_dim=STATE + K, num_tasks=K)
    loss = MTPPOLoss(actor, critic, num_tasks=K)
    x, tid = _data()
    obs = torch.cat([x, torch.nn.functional.one_hot(tid, K).float()], -1)
    td = TensorDict({"observation": obs, "task_id": tid}, [N])
    with torch.no_grad():
        actor(td)
    g = torch.Generator().manual_seed(5)
    td["advantage"] = torch.randn(N, 1, generator=g) + tid[:, None].float()
    td["value_target"] = torch.randn(N, 1, generator=g)
    td["state_value"] = td["value_target"] + 0.1 * torch.randn(N, 1, generator=g)
    td["action"] = td["action"] + 0.3 * torch.randn(td["action"].shape, generator=g)  # ratios != 1
    opt = torch.optim.Adam(loss.parameters(), lr=1e-2)
    module = make_gradient_method(grad, loss, K)
    update = MinibatchUpdate(module, opt, max_grad_norm=0.5, call_hooks=lambda point, metrics: None)
    metrics = update.step(td[rows])
    out = {name: p.detach().clone() for name, p in loss.named_parameters()}
    out.update({f"metric/{k}": v.detach().clone() for k, v in metrics.items() if v.numel() == 1})
    return out


def _ppo_step_on_half(rank: int, grad: str = "none") -> dict[str, torch.Tensor]:
    return _ppo_step(slice(rank * (N // 2), (rank + 1) * (N // 2)), grad)


@pytest.mark.parametrize("grad", ["none", "pcgrad", "cagrad", "famo"])
def test_one_update_of_two_processes_equals_one_process_on_the_whole_minibatch(grad: str) -> None:
    """For the gradient methods: every task's gradient (PCGrad, CAGrad) and loss (FAMO's weights) over both
    processes' samples."""
    single = _ppo_step(slice(None), grad)
    ranks = run_ranks(functools.partial(_ppo_step_on_half, grad=grad))
    for key, value in single.items():
        if key == "metric/explained_variance":  # a ratio of the batch's variances: the ranks' mean, not the union's
            continue
        for out in ranks:
            torch.testing.assert_close(out[key], value, rtol=1e-5, atol=1e-6, msg=key)
    # the same update from one process on half the data differs: the test can fail
    half = _ppo_step(slice(0, N // 2), grad)
    assert any(not torch.allclose(half[k], single[k]) for k in single if not k.startswith("metric/"))


# ---------------------------------------------------------------------------------------------- settings
def test_context_from_torchrun_variables() -> None:
    assert context_from_environment({}) is None
    assert context_from_environment({"WORLD_SIZE": "1", "RANK": "0"}) is None
    ctx = context_from_environment({"WORLD_SIZE": "4", "RANK": "5", "LOCAL_RANK": "1"})
    assert (ctx.rank, ctx.world_size, ctx.local_rank, ctx.is_main) == (5, 4, 1, False)
    with pytest.raises(ValueError, match="RANK is not set"):
        context_from_environment({"WORLD_SIZE": "2"})


def _cfg(**changes: Any) -> Any:
    base = {"loss": {"name": "ppo"}, "grad": {"name": "none"}, "env": {"name": "mt10", "num_envs": 64},
            "device": "auto", "cudagraph_update": "auto", "pretrained": None, "resume": None}
    for key, value in changes.items():
        section, _, field = key.partition("__")
        if field:
            base[section][field] = value
        else:
            base[section] = value
    return OmegaConf.create(base)


@pytest.mark.parametrize(("changes", "match"), [
    ({"loss": {"name": "sac", "batch_size": 8192, "replay_buffer_size": 1000001}},
     r"loss.replay_buffer_size=1000001 must be divisible by the number of torchrun processes \(2\)"),
    ({"env__num_envs": 63}, r"env.num_envs=63 must be divisible by the number of torchrun processes \(2\)"),
    ({"cudagraph_update": True}, "cudagraph_update=true does not run under torchrun"),
    ({"device": "cuda:1"}, "device=cuda:1: under torchrun each process takes cuda:<LOCAL_RANK>"),
])
def test_what_does_not_split_over_processes_is_one_clear_error(changes: dict[str, Any], match: str) -> None:
    ctx = DistributedContext(0, 2, 0)
    check_distributed(_cfg(), ctx)  # the base config splits
    with pytest.raises(ValueError, match=match):
        check_distributed(_cfg(**changes), ctx)


def test_rank_files() -> None:
    assert rank_file("/r/checkpoints/last.pt", 0) == Path("/r/checkpoints/last.pt")
    assert rank_file("/r/checkpoints/last.pt", 3) == Path("/r/checkpoints/rank3/last.pt")


# ---------------------------------------------------------------------------------------------- the front door
PPO_SIZES = ("env=cpu_small", "env.num_envs=12", "loss=ppo", "loss.horizon=8", "loss.minibatch_size=48",
             "loss.epochs=2")


def _torchrun(tmp_path: Path, nproc: int, *overrides: str, sizes: tuple[str, ...] = PPO_SIZES
              ) -> subprocess.CompletedProcess[str]:
    tmp_path.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "torch.distributed.run", f"--nproc_per_node={nproc}", "--master_port",
           str(_free_port()), str(ROOT / "examples" / "train.py"), "device=cpu", *sizes,
           "torch_threads=1", f"checkpoint.dir={tmp_path / 'ck'}", f"logging.log_dir={tmp_path / 'logs'}",
           "logging.exp_name=ddp", f"hydra.run.dir={tmp_path / 'hydra'}", "logging.progress=none", *overrides]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env, cwd=tmp_path)


def test_two_process_run_checkpoints_each_rank_and_resumes_only_with_two(tmp_path: Path) -> None:
    run = _torchrun(tmp_path, 2, "max_iterations=2")
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert run.stdout.count("mtbench | ppo") == 1  # one process prints
    assert "envs=12 " in run.stdout and "(2 processes x 24)" in run.stdout  # the run's totals, each rank's share
    main, other = load_checkpoint(tmp_path / "ck" / "final.pt"), load_checkpoint(tmp_path / "ck" / "rank1" / "final.pt")
    assert main["distributed"] == {"rank": 0, "world_size": 2}
    assert other["distributed"] == {"rank": 1, "world_size": 2}
    assert main["counters"]["frames"] == 2 * 12 * 8  # the run's frames, both processes
    for key, value in main["loss"].items():  # the networks stayed equal on both ranks
        torch.testing.assert_close(other["loss"][key], value, msg=key)
    # each rank simulated its own worlds
    assert not torch.equal(main["rollout"]["carry"]["observation"], other["rollout"]["carry"]["observation"])
    assert list((tmp_path / "logs").glob("ddp*.mcap"))  # rank 0 logged

    one = subprocess.run([sys.executable, str(ROOT / "examples" / "train.py"), "device=cpu", "env=cpu_small",
                          "loss=ppo", "env.num_envs=12", "loss.horizon=8", "loss.minibatch_size=48",
                          "max_iterations=3", f"resume={tmp_path / 'ck' / 'last.pt'}", "logging.logger=none",
                          f"hydra.run.dir={tmp_path / 'hydra1'}"],
                         capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert one.returncode != 0
    assert "processes: checkpoint=rank 0 of 2 current=rank 0 of 1" in one.stderr

    again = _torchrun(tmp_path, 2, "max_iterations=3", f"resume={tmp_path / 'ck' / 'last.pt'}")
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert "resumed from" in again.stdout and "at iteration 2" in again.stdout
    assert load_checkpoint(tmp_path / "ck" / "rank1" / "final.pt")["counters"]["iteration"] == 3


def test_two_process_sac_run_keeps_the_networks_equal(tmp_path: Path) -> None:
    """MT-SAC: each process replays half of every batch from its own buffer; after the updates the two processes'
    actor, Q networks, target networks and temperatures are the same."""
    run = _torchrun(tmp_path, 2, "max_iterations=6", "loss.warmup_steps=2", "loss.batch_size=64",
                    "loss.replay_buffer_size=2000", sizes=("env=cpu_small", "env.num_envs=12", "loss=sac"))
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "2 updates of 64 replayed" in run.stdout and "(2 processes x 32, buffers of 1,000)" in run.stdout
    main, other = load_checkpoint(tmp_path / "ck" / "final.pt"), load_checkpoint(tmp_path / "ck" / "rank1" / "final.pt")
    assert main["counters"]["updates"] == other["counters"]["updates"] > 0
    for key, value in main["loss"].items():
        torch.testing.assert_close(other["loss"][key], value, msg=key)


def test_two_process_parkour_run_trains_its_flat_stage_then_reuses_it(tmp_path: Path) -> None:
    """The headline command's two stages under torchrun (the CI's tiny grid): all ranks train the flat stage, then
    fine-tune from it; a second run reuses the stage."""
    tiny = ("env=parkour_hard_cl", "env.num_envs=42", "loss=ppo", "arch=moore", "env.overrides.num_rows=2",
            "pretrain.iterations=2", f"pretrain.dir={tmp_path / 'pretrained'}")
    first = _torchrun(tmp_path, 2, "max_iterations=2", sizes=tiny)
    assert first.returncode == 0, first.stdout[-3000:] + first.stderr[-3000:]
    assert first.stdout.count("flat pre-training: 2 iterations on parkour_flat") == 1  # one process prints
    assert "== stage 2/2: parkour_hard_cl" in first.stdout
    stage = next((tmp_path / "pretrained").glob("moore-*"))
    main = load_checkpoint(stage / "checkpoints" / "final.pt")
    other = load_checkpoint(stage / "checkpoints" / "rank1" / "final.pt")
    assert main["distributed"]["world_size"] == 2 and main["counters"]["iteration"] == 2
    for key, value in main["loss"].items():
        torch.testing.assert_close(other["loss"][key], value, msg=key)
    again = _torchrun(tmp_path / "again", 2, "max_iterations=1", sizes=tiny)
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert f"flat pre-training: reusing {stage / 'checkpoints' / 'final.pt'}" in again.stdout
