"""Run the scripted policies in the batched env and report per-task success rates.

``python -m mtbench.envs.metaworld.policies.evaluate reach push --worlds 5`` prints one line per task.
"""

from __future__ import annotations

import argparse
from typing import Sequence

import torch

from ....envs.make import make_env
from . import scripted_policy


def evaluate_scripted(
    tasks: Sequence[str], worlds_per_task: int = 5, *, seed: int = 0, device: str = "cpu", rand: bool = True,
    **env_overrides,
) -> dict[str, float]:
    """Fraction of episodes (one per world, randomized object/goal) solved by each task's scripted policy."""
    env = make_env(list(tasks), num_envs=[worlds_per_task] * len(tasks), device=device, seed=seed, rand=rand,
                   random_start_progress=False, **env_overrides)
    policies = [scripted_policy(t) for t in tasks]
    td = env.reset()
    for _ in range(env.max_episode_steps):
        obs = td["observation"][:, : env.state_dim]
        td["action"] = torch.cat([p(obs[sl]) for p, sl in zip(policies, env.slices)])
        _, td = env.step_and_maybe_reset(td)
    stats = env.pop_episode_stats()
    rates = (stats["success"] / stats["episodes"].clamp_min(1)).tolist()
    return dict(zip(tasks, rates))


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("tasks", nargs="+")
    parser.add_argument("--worlds", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--fixed", action="store_true", help="sample object/goal once per world")
    args = parser.parse_args(argv)
    for task, rate in evaluate_scripted(args.tasks, args.worlds, seed=args.seed, device=args.device,
                                        rand=not args.fixed).items():
        print(f"{task:24s} success {rate:6.1%}")


if __name__ == "__main__":
    main()
