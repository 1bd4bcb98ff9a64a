"""GPU correctness check: TorchRL spec check and a seeded rollout on the CUDA device (run on the GPU host)."""

from __future__ import annotations

import sys

import torch
from torchrl.envs.utils import check_env_specs

from mtbench.envs import make_env

name = sys.argv[1] if len(sys.argv) > 1 else "mt10"
env = make_env(name, num_envs=int(sys.argv[2]) if len(sys.argv) > 2 else 64, device="cuda", seed=0)
check_env_specs(env)
print(f"check_env_specs passed for {name} on {env.device} ({torch.cuda.get_device_name()})")
td = env.rollout(200, break_when_any_done=False)
print("rollout reward mean", td["next", "reward"].mean().item(), "finite",
      bool(torch.isfinite(td["next", "observation"]).all()), "stats", env.pop_episode_stats().to_dict())
