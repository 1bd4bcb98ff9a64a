"""Can MT-PQN's action space solve a task? The scripted controllers under PQN's bang-off-bang actions, per step or
held for a whole rollout.

MT-PQN (docs/pqn.md) acts with 3 bins per action dimension ({-1, 0, +1}: bang-off-bang) on MTBench's discrete task
config (500-step episodes, end-effector step 0.005 m), and with MTBench's held rollout observation
(``loss.hold_observation``) its greedy action is the same for all 16 steps of a rollout. This script drives each
task's scripted controller (``mtbench.envs.metaworld.policies``) through randomized episodes of that config in
three action modes and prints the success rates:

* ``continuous``: the controller's own action;
* ``bang``: each component turned into bins by error diffusion (sigma-delta: the bin nearest to the action plus
  the rounding error carried from earlier steps), so that the bins average to the controller's action; every step;
* ``bang_hold<K>``: the action rounded to the nearest bin, decided only every K steps (at steps 0, K, 2K, ... of the
  episode) and held in between, as a greedy policy on a held rollout observation acts (K = 16: MTBench's horizon).

``bang`` shows whether per-step bang-off-bang actions can do a task; ``bang_hold<K>`` what a rounded controller
reaches with K-step commitments, a lower bound, not what the best held policy could.

    python benchmarks/pqn_action_repeat.py --worlds 8            # MT10 tasks, CPU, a few minutes
    python benchmarks/pqn_action_repeat.py push reach --worlds 16 --hold 1 4 16     # 1: error diffusion
"""

from __future__ import annotations

import argparse
from typing import Sequence

import torch

from mtbench.envs.make import make_env
from mtbench.envs.metaworld.policies import scripted_policy
from mtbench.envs.metaworld.registry import MT10

EPISODE_LENGTH = 500  # MTBench's discrete task config (meta-world-discrete-v2.yaml)
ACTION_SCALE = 0.005


def bang_off_bang(action: torch.Tensor) -> torch.Tensor:
    """Each component to the nearest of {-1, 0, +1} (PQN's 3 bins of [-1, 1])."""
    return torch.round(action.clamp(-1.0, 1.0))


class ErrorDiffusion:
    """Bins whose running sum follows the running sum of the actions (first-order sigma-delta modulation)."""

    def __init__(self) -> None:
        self.carry: torch.Tensor | None = None

    def __call__(self, action: torch.Tensor) -> torch.Tensor:
        wanted = action.clamp(-1.0, 1.0) + (0.0 if self.carry is None else self.carry)
        out = bang_off_bang(wanted)
        self.carry = wanted - out
        return out


def success_rates(tasks: Sequence[str], worlds: int, mode: str, hold: int = 1, seed: int = 0,
                  device: str = "cpu") -> list[float]:
    """Per-task success rate of the scripted controllers in ``mode`` (``continuous``, or ``bang``: error diffusion
    with ``hold=1``, the nearest bin held for ``hold`` steps otherwise), one randomized episode of
    ``EPISODE_LENGTH`` steps per world."""
    env = make_env(list(tasks), num_envs=[worlds] * len(tasks), device=device, seed=seed, rand=True,
                   random_start_progress=False, episode_length=EPISODE_LENGTH, action_scale=ACTION_SCALE)
    policies = [scripted_policy(t) for t in tasks]
    td = env.reset()
    held, diffuse = None, ErrorDiffusion()
    for t in range(env.max_episode_steps):
        obs = td["observation"][:, : env.state_dim]
        action = torch.cat([p(obs[sl]) for p, sl in zip(policies, env.slices)])
        if mode == "bang" and hold == 1:
            action = diffuse(action)
        elif mode == "bang":
            if t % hold == 0:
                held = bang_off_bang(action)
            action = held
        td["action"] = action
        _, td = env.step_and_maybe_reset(td)
    stats = env.pop_episode_stats()
    return (stats["success"] / stats["episodes"].clamp_min(1)).tolist()


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("tasks", nargs="*", default=list(MT10), help="Meta-World tasks (default: MT10)")
    parser.add_argument("--worlds", type=int, default=8, help="randomized episodes per task")
    parser.add_argument("--hold", type=int, nargs="+", default=[1, 16], help="bang-off-bang decision periods")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.worlds < 1 or any(h < 1 for h in args.hold):
        parser.error("--worlds and every --hold must be >= 1")
    columns = {"continuous": success_rates(args.tasks, args.worlds, "continuous", seed=args.seed)}
    for k in args.hold:
        columns["bang" if k == 1 else f"bang_hold{k}"] = success_rates(args.tasks, args.worlds, "bang", k,
                                                                       seed=args.seed)
    print(f"scripted controllers, {args.worlds} randomized episodes per task, {EPISODE_LENGTH} steps, "
          f"end-effector step {ACTION_SCALE} m (MT-PQN's Meta-World config)")
    print(f"{'task':24s}" + "".join(f"{name:>16s}" for name in columns))
    for i, task in enumerate(args.tasks):
        print(f"{task:24s}" + "".join(f"{100 * col[i]:15.1f}%" for col in columns.values()))
    print(f"{'mean':24s}" + "".join(f"{100 * sum(col) / len(col):15.1f}%" for col in columns.values()))


if __name__ == "__main__":
    main()
