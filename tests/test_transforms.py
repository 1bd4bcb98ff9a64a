"""Per-task running statistics and the per-task observation normaliser."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torchrl.envs import TransformedEnv
from torchrl.envs.utils import check_env_specs

from envs_for_tests import SyntheticMTEnv
from mtbench.transforms import PerTaskObservationNorm, PerTaskRunningMeanStd


def _numpy_stats(chunks: list[tuple[np.ndarray, np.ndarray]], k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = np.concatenate([c[0] for c in chunks])
    t = np.concatenate([c[1] for c in chunks])
    count = np.array([(t == i).sum() for i in range(k)], dtype=np.float64)
    mean = np.stack([x[t == i].mean(0) if (t == i).any() else np.zeros(x.shape[1]) for i in range(k)])
    var = np.stack([x[t == i].var(0) if (t == i).any() else np.ones(x.shape[1]) for i in range(k)])
    return count, mean, var


def test_running_mean_std_matches_numpy() -> None:
    rng = np.random.default_rng(0)
    k, d = 4, 3
    rms = PerTaskRunningMeanStd(k, d)
    chunks = []
    for size, tasks in [(7, [0, 1]), (50, [0, 1, 2]), (1, [2]), (33, [1, 2]), (120, [0, 1, 2])]:  # task 3 never seen
        t = rng.choice(tasks, size=size)
        x = rng.normal(loc=t[:, None] * 10.0, scale=1.0 + t[:, None], size=(size, d)).astype(np.float32)
        chunks.append((x.astype(np.float64), t))
        rms.update(torch.from_numpy(x), torch.from_numpy(t))
        count, mean, var = _numpy_stats(chunks, k)
        np.testing.assert_allclose(rms.count.numpy(), count)
        np.testing.assert_allclose(rms.mean.numpy(), mean, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(rms.var.numpy(), var, rtol=1e-6, atol=1e-6)
    # unseen task keeps the identity statistics
    assert torch.equal(rms.mean[3], torch.zeros(d, dtype=torch.float64))
    assert torch.equal(rms.var[3], torch.ones(d, dtype=torch.float64))


def test_running_mean_std_skips_non_finite_and_masked_rows() -> None:
    x = torch.tensor([[1.0], [3.0], [float("nan")], [100.0], [5.0]])
    t = torch.tensor([0, 0, 0, 0, 1])
    mask = torch.tensor([True, True, True, False, True])
    rms = PerTaskRunningMeanStd(2, 1)
    rms.update(x, t, mask=mask)
    assert rms.count.tolist() == [2.0, 1.0]
    assert rms.mean[:, 0].tolist() == [2.0, 5.0]
    assert rms.var[:, 0].tolist() == [1.0, 0.0]


def test_normalize_denormalize_and_clip() -> None:
    rms = PerTaskRunningMeanStd(2, 2, eps=1e-8)
    x = torch.tensor([[0.0, 10.0], [2.0, 14.0], [-5.0, 0.0]])
    t = torch.tensor([0, 0, 1])
    rms.update(x, t)
    y = rms.normalize(x, t)
    expected = torch.tensor([[-1.0, -1.0], [1.0, 1.0], [0.0, 0.0]])
    torch.testing.assert_close(y, expected, atol=1e-6, rtol=0)
    torch.testing.assert_close(rms.denormalize(y, t), x, atol=1e-5, rtol=0)
    clipped = PerTaskRunningMeanStd(1, 1, clip=5.0)
    clipped.update(torch.tensor([[0.0], [2.0]]), torch.tensor([0, 0]))
    assert clipped.normalize(torch.tensor([[100.0]]), torch.tensor([0])).item() == 5.0
    # denormalize clamps its input first (rl_games RunningMeanStd(denorm=True))
    assert clipped.denormalize(torch.tensor([[9.0]]), torch.tensor([0])).item() == pytest.approx(1.0 + 5.0)


def _rollout(env, steps: int, seed: int = 1) -> list[torch.Tensor]:
    gen = torch.Generator().manual_seed(seed)
    td = env.reset()
    obs = [td["observation"].clone()]
    for _ in range(steps):
        td["action"] = torch.rand(env.batch_size[0], 2, generator=gen) * 2 - 1
        _, td = env.step_and_maybe_reset(td)
        obs.append(td["observation"].clone())
    return obs


def test_observation_norm_matches_cumulative_numpy_stats() -> None:
    raw_env = SyntheticMTEnv([3, 2, 4], max_episode_steps=5, seed=3)
    norm_env = TransformedEnv(SyntheticMTEnv([3, 2, 4], max_episode_steps=5, seed=3), PerTaskObservationNorm(3))
    raw = _rollout(raw_env, 12)
    normed = _rollout(norm_env, 12)
    task = raw_env.task_id.numpy()
    s = raw_env.state_dim
    seen: list[np.ndarray] = []
    for r, n in zip(raw, normed):
        # the one-hot is untouched
        assert torch.equal(n[:, s:], r[:, s:])
        seen.append(r[:, :s].numpy().astype(np.float64))
        allx = np.concatenate(seen)
        allt = np.tile(task, len(seen))
        for k in range(3):
            mu, var = allx[allt == k].mean(0), allx[allt == k].var(0)
            expected = (r[task == k, :s].numpy() - mu) / np.sqrt(var + 1e-8)
            np.testing.assert_allclose(n[task == k, :s].numpy(), expected, rtol=1e-4, atol=1e-4)


def test_observation_norm_freeze_and_state_dict_round_trip() -> None:
    env = TransformedEnv(SyntheticMTEnv([2, 2], max_episode_steps=4, seed=0), PerTaskObservationNorm(2))
    check_env_specs(env)
    _rollout(env, 6)
    transform = env.transform
    transform.freeze()
    before = {k: v.clone() for k, v in transform.state_dict().items()}
    _rollout(env, 3)
    for key, value in transform.state_dict().items():
        assert torch.equal(value, before[key]), key
    transform.unfreeze()
    _rollout(env, 2)
    assert transform.stats.count[0] > before["stats.count"][0]

    # a fresh transform (state_dim inferred lazily) restores the statistics exactly
    fresh = PerTaskObservationNorm(2)
    fresh.load_state_dict(transform.state_dict())
    fresh.freeze()
    transform.freeze()
    obs = torch.randn(5, env.base_env.state_dim + 2)
    tid = torch.tensor([0, 1, 1, 0, 1])
    torch.testing.assert_close(fresh.normalize(obs, tid), transform.normalize(obs, tid), rtol=0, atol=0)


def test_observation_norm_rejects_wrong_width() -> None:
    transform = PerTaskObservationNorm(3, state_dim=4)
    with pytest.raises(ValueError, match="state_dim"):
        transform.normalize(torch.zeros(2, 5), torch.zeros(2, dtype=torch.long))
