"""GPU correctness check (run on the GPU host): TorchRL spec check, and the CUDA-graph replay of the env's torch
stages against the same stages run eagerly from the same state.

    python benchmarks/gpu_check.py mt10 256
    python benchmarks/gpu_check.py parkour_hard 1024 30

Each trial saves the full env state, takes one step with the graphs, restores the state, takes the same step
eagerly, and compares observation, reward and done (worlds that reset during the step included). The physics
graphs are shared by both paths, so differences can only come from the torch stages (or float atomics).
"""

from __future__ import annotations

import copy
import sys

import torch
from torchrl.envs.utils import check_env_specs

from mtbench.envs import make_env


def main() -> None:
    name = sys.argv[1] if len(sys.argv) > 1 else "mt10"
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 256
    trials = int(sys.argv[3]) if len(sys.argv) > 3 else 40
    overrides = {"num_rows": 2} if name.startswith("parkour") else {}  # a small terrain grid is enough here
    env = make_env(name, num_envs=n, device="cuda", seed=0, **overrides)
    action_dim = int(env.action_spec.shape[-1])
    check_env_specs(env)
    print(f"check_env_specs passed for {name} on {env.device} ({torch.cuda.get_device_name()})", flush=True)
    env.reset()
    gen = torch.Generator(device=env.device).manual_seed(1)
    for _ in range(5):  # eager warm-up steps, then the stages are captured
        env._core_step(torch.rand(n, action_dim, generator=gen, device=env.device) * 2 - 1)
    assert all(stage.captured for stage in env._stages), "stages were not captured"
    worst_obs, worst_rew, done_mismatch, resets = 0.0, 0.0, 0, 0
    col_diff = torch.zeros(env.observation_spec["observation"].shape[-1], device=env.device)
    for _ in range(trials):
        state = copy.deepcopy(env.get_extra_state())
        action = torch.rand(n, action_dim, generator=gen, device=env.device) * 2 - 1
        graphed = env._core_step(action)
        after = copy.deepcopy(env.get_extra_state())
        env.set_extra_state(state)
        for stage in env._stages:
            stage.enabled = False
        eager = env._core_step(action)
        for stage in env._stages:
            stage.enabled = True
        env.set_extra_state(after)  # continue from the graphed trajectory
        diff = (graphed["observation"] - eager["observation"]).abs()
        col_diff = torch.maximum(col_diff, diff.amax(0))
        worst_obs = max(worst_obs, float(diff.max()))
        worst_rew = max(worst_rew, float((graphed["reward"] - eager["reward"]).abs().max()))
        done_mismatch += int((graphed["done"] != eager["done"]).sum())
        resets += int(graphed["done"].sum())
    print(f"graph vs eager over {trials} steps x {n} worlds ({resets} resets): max |d obs| {worst_obs:.3e}, "
          f"max |d reward| {worst_rew:.3e}, done mismatches {done_mismatch}", flush=True)
    print("largest observation differences by field:", _field_diffs(env, col_diff.cpu()), flush=True)
    td = env.rollout(200, break_when_any_done=False)
    # TorchRL marks the ("next", "observation") of autoreset steps as unknown (NaN); every observation the
    # policy sees is in "observation"
    not_done = ~td["next", "done"].squeeze(-1)
    finite = bool(torch.isfinite(td["observation"]).all()) and bool(
        torch.isfinite(td["next", "observation"][not_done]).all())
    print("rollout reward mean", td["next", "reward"].mean().item(), "finite", finite,
          "stats", {k: v.tolist() for k, v in env.pop_episode_stats().items()})
    ok = worst_obs < 1e-3 and worst_rew < 1e-2 and done_mismatch == 0 and finite
    print("GPU CHECK", "PASSED" if ok else "FAILED")
    sys.exit(0 if ok else 1)


def _field_diffs(env, col_diff: torch.Tensor) -> dict[str, float]:
    """Max graph-vs-eager difference per named observation field (the env family's layout module)."""
    if type(env).__name__ == "ParkourEnv":
        from mtbench.envs.parkour.observation import SLICES
    else:
        from mtbench.envs.metaworld.observation import FIELD

        SLICES = {name: f.slice for name, f in FIELD.items()}
    diffs = {name: float(col_diff[sl].max()) for name, sl in SLICES.items()}
    return {k: round(v, 6) for k, v in sorted(diffs.items(), key=lambda kv: -kv[1])[:6] if v > 0}


if __name__ == "__main__":
    main()
