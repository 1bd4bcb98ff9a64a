"""Is a stalled Meta-World policy blocked by the scene, or does it just stop? A diagnostic of a checkpoint.

The trained policy acts deterministically (its Gaussian mean) for ``--steer-from`` steps; from there on, in the
worlds of the probed tasks, a proportional controller replaces its hand motion and steers the object straight at
its goal (``xyz = clip(gain * (goal - object), -1, 1)``, the gripper action still the policy's, so a held object
stays held). If the object then reaches the goal, the way from where the policy stopped is physically free and
the env's reward along it is what the policy forwent; if not, the scene blocks the straight way.

Prints, per probed task: the object's distance to its goal at chosen steps, the mean env reward per step over the
last 10 policy steps and over the steered steps, the episode success, and the object's height and the hand's
distance to it at the policy's last step. With ``--steer-from 149`` it is a trace of the policy alone.

    python benchmarks/carry_probe.py --checkpoint runs/mt50/checkpoints/final.pt --worlds-per-task 2 \\
        --tasks push_wall pick_place_wall shelf_place stick_pull basketball peg_insert_side pick_place
"""

from __future__ import annotations

import argparse
from typing import Sequence

import torch
from omegaconf import OmegaConf

from mtbench.evaluation.policy import checkpoint_num_tasks, load_policy, make_eval_env, read_checkpoint


def probe(checkpoint: str, tasks: Sequence[str], worlds_per_task: int, steer_from: int, gain: float,
          device: str = "cpu", seed: int = 43) -> dict[str, dict[str, torch.Tensor]]:
    """Run the probe (one episode per world); per task: ``distance`` ``[T, worlds]`` (object to goal after each
    step), ``reward`` ``[T, worlds]``, and the episodes that succeeded at any step out of those finished."""
    state = read_checkpoint(checkpoint)
    cfg = OmegaConf.create(state["config"])
    dev = torch.device(device)
    env = make_eval_env(cfg.env, worlds_per_task * _task_count(state), dev, seed)
    try:
        unknown = [t for t in tasks if t not in env.task_names]
        if unknown:
            raise ValueError(f"unknown tasks {unknown} for this checkpoint; valid choices: {list(env.task_names)}")
        if not 0 <= steer_from < env.max_episode_steps:
            raise ValueError(f"steer_from={steer_from} is out of range; it must be in "
                             f"[0, {env.max_episode_steps - 1}]")
        policy = load_policy(state, env, dev)
        index = {t: env.task_names.index(t) for t in tasks}
        states = {t: env.blocks[i][1] for t, i in index.items()}
        env.set_seed(seed)
        torch.manual_seed(seed)
        td = env.reset()
        distance: dict[str, list[torch.Tensor]] = {t: [] for t in tasks}
        height: dict[str, list[torch.Tensor]] = {t: [] for t in tasks}
        hand: dict[str, list[torch.Tensor]] = {t: [] for t in tasks}
        reward: dict[str, list[torch.Tensor]] = {t: [] for t in tasks}
        for step in range(env.max_episode_steps):
            action = policy(td, True)
            if step >= steer_from:
                for t, i in index.items():
                    s = states[t]
                    action[env.slices[i], :3] = torch.clamp(gain * (s.goal - s.obj_pos), -1.0, 1.0)
            td["action"] = action
            out, td = env.step_and_maybe_reset(td)
            for t, i in index.items():
                s = states[t]
                distance[t].append((s.obj_pos - s.goal).norm(dim=-1).clone())
                height[t].append(s.obj_pos[:, 2].clone())
                hand[t].append((s.tcp - s.obj_pos).norm(dim=-1).clone())
                reward[t].append(out["next", "reward"][env.slices[i]].reshape(-1).clone())
        stats = env.pop_episode_stats()
    finally:
        env.close()
    return {t: {"distance": torch.stack(distance[t]).cpu(), "height": torch.stack(height[t]).cpu(),
                "hand": torch.stack(hand[t]).cpu(), "reward": torch.stack(reward[t]).cpu(),
                "successes": int(stats["success"][i]), "episodes": int(stats["episodes"][i])}
            for t, i in index.items()}


def _task_count(state: dict) -> int:
    n = checkpoint_num_tasks(state)
    if n is None:
        raise ValueError("the checkpoint does not record its number of tasks")
    return n


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", required=True)
    parser.add_argument("--tasks", nargs="+", required=True)
    parser.add_argument("--worlds-per-task", type=int, default=2)
    parser.add_argument("--steer-from", type=int, default=100)
    parser.add_argument("--gain", type=float, default=20.0)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--seed", type=int, default=43)
    args = parser.parse_args(argv)
    if args.worlds_per_task < 1:
        parser.error(f"--worlds-per-task={args.worlds_per_task} is out of range; it must be an integer >= 1")
    result = probe(args.checkpoint, args.tasks, args.worlds_per_task, args.steer_from, args.gain, args.device,
                   args.seed)
    k = args.steer_from
    last = next(iter(result.values()))["distance"].shape[0] - 2  # after the last step the worlds autoreset
    marks = sorted({m for m in (0, k // 2, k - 1, k + 9, k + 19, k + 34, last) if 0 <= m <= last})
    print(f"object-goal distance (m, mean over {args.worlds_per_task} worlds) after steps {marks}; policy until "
          f"step {k}, then steered at the goal (gain {args.gain})")
    print(f"| task | {' | '.join(f'd@{m}' for m in marks)} | reward/step, last 10 policy steps | reward/step, "
          f"steered | success |")
    print("|---|" + "---:|" * (len(marks) + 3))
    for t, r in result.items():
        d = r["distance"].mean(-1)
        before = r["reward"][max(0, k - 10):k].mean().item()
        after = f"{r['reward'][k:last + 1].mean().item():.2f}" if k <= last else "-"  # no steered step counted
        print(f"| {t} | {' | '.join(f'{d[m]:.3f}' for m in marks)} | {before:.2f} | {after} | "
              f"{r['successes']}/{r['episodes']} |")
    stop = max(0, min(k, last + 1) - 1)
    print(f"\nat step {stop}, the policy's last step before the steering (m, mean over {args.worlds_per_task} worlds)")
    print("| task | object height | hand to object |")
    print("|---|---:|---:|")
    for t, r in result.items():
        print(f"| {t} | {r['height'][stop].mean():.3f} | {r['hand'][stop].mean():.3f} |")


if __name__ == "__main__":
    main()
