"""``group_models`` against one model per task on a whole Meta-World setting: both envs, same seed, the scripted
controllers of every task for ``steps`` steps (past the first episode's end), then the largest differences of
observations, rewards and dones, and each env's per-task success.

    python benchmarks/group_check.py                          # MT50-rand, 2 worlds per task, CPU (a minute)
    python benchmarks/group_check.py mt50_rand 16 cuda 200    # on the GPU host

On the CPU every world does the same float operations in the shared model as in its own: the check passes only when
everything is exactly equal. On the GPU, float atomics make physics runs differ slightly from run to run, and
contacts amplify it; the figures there say how far apart the two layouts drift.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mtbench.envs import make_env  # noqa: E402
from mtbench.envs.metaworld.policies import scripted_policy  # noqa: E402
from mtbench.envs.metaworld.registry import benchmark_tasks  # noqa: E402
from _timing import sync  # noqa: E402


def rollout(name: str, per_task: int, device: str, steps: int, group_models: bool) -> dict:
    """The scripted controllers' rollout: stacked observations, rewards and dones, episode statistics, timing."""
    counts = [per_task] * len(benchmark_tasks(name.removesuffix("_rand")))
    env = make_env(name, num_envs=counts, device=device, seed=5, group_models=group_models, episode_length=120,
                   random_start_progress=False)
    policies = [scripted_policy(t) for t in env.task_names]
    td = env.reset()
    obs, reward, done = [], [], []
    sync(env.device)
    t0 = time.perf_counter()
    for _ in range(steps):
        o = td["observation"][:, : env.state_dim]
        td["action"] = torch.cat([p(o[sl]) for p, sl in zip(policies, env.slices)])
        out, td = env.step_and_maybe_reset(td)
        obs.append(td["observation"])
        reward.append(out["next", "reward"])
        done.append(out["next", "done"])
    sync(env.device)
    ms = (time.perf_counter() - t0) * 1e3 / steps
    stats = env.pop_episode_stats()
    return {"blocks": len(env.sims), "obs": torch.stack(obs), "reward": torch.stack(reward),
            "done": torch.stack(done), "success": stats["success"] / stats["episodes"].clamp_min(1), "ms": ms,
            "tasks": env.task_names}


def main() -> None:
    name = sys.argv[1] if len(sys.argv) > 1 else "mt50_rand"
    per_task = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    device = sys.argv[3] if len(sys.argv) > 3 else "cpu"
    steps = int(sys.argv[4]) if len(sys.argv) > 4 else 150
    a = rollout(name, per_task, device, steps, group_models=False)
    b = rollout(name, per_task, device, steps, group_models=True)
    print(f"{name}: {per_task} worlds per task on {device}, {steps} steps of the scripted controllers (episodes of 120)")
    print(f"physics blocks {a['blocks']} -> {b['blocks']} | ms per step (eager, incl. the controllers) "
          f"{a['ms']:.1f} -> {b['ms']:.1f}")
    exact = True
    for key in ("obs", "reward", "done"):
        x, y = a[key], b[key]
        diff = float((x.float() - y.float()).abs().max())
        exact &= bool(torch.equal(x, y))
        print(f"  {key:7s} max |difference| {diff:.3e}" + (f" ({int((x != y).sum())} entries differ)" if diff else ""))
    print(f"  mean success of the scripted controllers: {float(a['success'].mean()):.1%} per task model, "
          f"{float(b['success'].mean()):.1%} grouped")
    for task, sa, sb in zip(a["tasks"], a["success"].tolist(), b["success"].tolist()):
        if sa != sb:
            print(f"  {task}: {sa:.0%} against {sb:.0%}")
    if device == "cpu":
        print("GROUP CHECK PASSED (exactly equal)" if exact else "GROUP CHECK FAILED: the CPU results differ")
        if not exact:
            raise SystemExit(1)


if __name__ == "__main__":
    main()
