"""Shared by the Meta-World env tests: seeded random actions and a rollout that stacks what each step returned."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase


def random_actions(env, steps: int, seed: int) -> torch.Tensor:
    """``[steps, N, 4]`` actions uniform in [-1, 1] from a seeded CPU generator."""
    g = torch.Generator().manual_seed(seed)
    return torch.rand(steps, env.batch_size[0], 4, generator=g) * 2 - 1


def rollout(env, actions: torch.Tensor, td: TensorDictBase | None = None):
    """Step ``env`` through ``actions`` (from ``td``, else a reset): the last root TensorDict and the stacked
    observations (the first one included), rewards, dones and per-world episode success flags."""
    td = env.reset() if td is None else td
    obs, rewards, dones, success = [td["observation"]], [], [], []
    for a in actions:
        td["action"] = a
        out, td = env.step_and_maybe_reset(td)
        obs.append(td["observation"])
        rewards.append(out["next", "reward"])
        dones.append(out["next", "done"])
        success.append(env._ep_success.clone())
    return td, torch.stack(obs), torch.stack(rewards), torch.stack(dones), torch.stack(success)
