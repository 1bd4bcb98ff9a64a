"""Reward along the scripted controllers' trajectories, per reward version.

For each task, the scripted policy drives ``--worlds`` randomized worlds through one 150-step episode in each
``reward_version``; the script prints the mean per-step env reward over each fifth of the episode, the episode
success rate, and the largest per-step difference between the versions (the same seed gives the same trajectory:
the reward does not act on the physics). It shows where a reward version pays along a successful path.

    python benchmarks/scripted_rewards.py basketball box_close dial_turn --worlds 8
"""

from __future__ import annotations

import argparse
from typing import Sequence

import torch

from mtbench.envs.make import make_env
from mtbench.envs.metaworld.policies import scripted_policy
from mtbench.envs.metaworld.task import REWARD_VERSIONS

PHASES = 5


def scripted_rewards(tasks: Sequence[str], worlds: int, version: str, seed: int = 0
                     ) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-step env rewards ``[T, tasks, worlds]`` and per-task success rates ``[tasks]`` of the scripted policies
    in ``reward_version=version`` (one randomized episode per world, on the CPU)."""
    env = make_env(list(tasks), num_envs=[worlds] * len(tasks), device="cpu", seed=seed, rand=True,
                   random_start_progress=False, reward_version=version)
    policies = [scripted_policy(t) for t in tasks]
    td = env.reset()
    rewards = []
    for _ in range(env.max_episode_steps):
        obs = td["observation"][:, : env.state_dim]
        td["action"] = torch.cat([p(obs[sl]) for p, sl in zip(policies, env.slices)])
        out, td = env.step_and_maybe_reset(td)
        rewards.append(out["next", "reward"].reshape(len(tasks), worlds).clone())
    stats = env.pop_episode_stats()
    return torch.stack(rewards), stats["success"] / stats["episodes"].clamp_min(1)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("tasks", nargs="+")
    parser.add_argument("--worlds", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    runs = {v: scripted_rewards(args.tasks, args.worlds, v, args.seed) for v in REWARD_VERSIONS}
    steps = next(iter(runs.values()))[0].shape[0]
    print(f"mean env reward per step over each fifth of the {steps}-step episode; {args.worlds} worlds per task, "
          f"seed {args.seed}")
    print(f"| task | version | {' | '.join(f'steps {i * steps // PHASES}-{(i + 1) * steps // PHASES - 1}' for i in range(PHASES))}"
          " | success | max per-step difference |")
    print("|---|---|" + "---:|" * (PHASES + 2))
    paper = runs["paper"][0]
    for i, task in enumerate(args.tasks):
        for version, (rewards, success) in runs.items():
            phases = rewards[:, i].mean(-1).reshape(PHASES, -1).mean(-1).tolist()
            diff = (rewards[:, i] - paper[:, i]).abs().max().item()
            cells = " | ".join(f"{x:.2f}" for x in phases)
            print(f"| {task} | {version} | {cells} | {success[i].item():.0%} | {diff:.3f} |")


if __name__ == "__main__":
    main()
