"""MT10 with mtbench's env and a MOORE actor, trained by stock TorchRL parts: one readable file (LeanRL style).

    python examples/custom_pipeline.py                                   # MT10, 20 worlds on the CPU, 10 iterations
    python examples/custom_pipeline.py --tasks reach,push --num-envs 4 --iterations 2
    python examples/custom_pipeline.py --device cuda --num-envs 4096 --iterations 200

mtbench parts: ``make_env`` (batched Meta-World on MuJoCo Warp, native autoreset), ``PerTaskObservationNorm``
(TorchRL transform), the MOORE network, the ``PCGrad`` loss wrapper and ``EpisodeStatsWindow`` (per-task success).
TorchRL parts: ``Collector``, ``ProbabilisticActor``, ``ClipPPOLoss`` and ``GAE`` (truncation bootstrap for the
native-autoreset env; advantages standardised per task with ``group_key="task_id"``).
"""

from __future__ import annotations

import argparse
import time

import torch
from tensordict.nn import InteractionType, TensorDictModule
from torchrl.collectors import Collector
from torchrl.envs import TransformedEnv
from torchrl.modules import IndependentNormal, ProbabilisticActor
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE

from mtbench.envs import make_env
from mtbench.modules import make_network
from mtbench.objectives import PCGrad, compute_gradients
from mtbench.trainer import EpisodeStatsWindow, GaussianPolicyHead
from mtbench.transforms import PerTaskObservationNorm


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tasks", default="mt10", help="mt10, mt10_rand, ... or comma-separated task names")
    p.add_argument("--num-envs", type=int, default=20, help="worlds, split evenly over the tasks")
    p.add_argument("--iterations", type=int, default=10,
                   help="iterations (10 x 32 steps: every world finishes a counted episode)")
    p.add_argument("--horizon", type=int, default=32, help="env steps per iteration")
    p.add_argument("--epochs", type=int, default=5)
    p.add_argument("--minibatches", type=int, default=4)
    p.add_argument("--device", default="cpu")
    p.add_argument("--seed", type=int, default=0)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> EpisodeStatsWindow:
    args = parse_args(argv)
    device = torch.device(args.device)
    torch.manual_seed(args.seed)

    # ---- env: mtbench's batched multi-task env + per-task input normalisation (a TorchRL transform)
    tasks = args.tasks if "," not in args.tasks else args.tasks.split(",")
    base_env = make_env(tasks, num_envs=args.num_envs, device=device, seed=args.seed)
    env = TransformedEnv(base_env, PerTaskObservationNorm(base_env.num_tasks, state_dim=base_env.state_dim))
    num_tasks = base_env.num_tasks
    obs_dim = env.observation_spec["observation"].shape[-1]
    action_dim = env.action_spec.shape[-1]

    # ---- networks: a MOORE actor (mixture of orthogonal experts) with a state-independent log-std, an MLP critic
    moore = make_network("moore", obs_dim=obs_dim, out_dim=action_dim, num_tasks=num_tasks,
                         num_experts=4, num_layers=2, hidden_dim=128, task_encoder=[64])
    actor = ProbabilisticActor(
        TensorDictModule(GaussianPolicyHead(moore, action_dim), in_keys=["observation", "task_id"],
                         out_keys=["loc", "scale"]),
        in_keys=["loc", "scale"],
        distribution_class=IndependentNormal,
        return_log_prob=True,
        default_interaction_type=InteractionType.RANDOM,
    ).to(device)
    critic = TensorDictModule(make_network("mlp", obs_dim=obs_dim, out_dim=1, num_tasks=num_tasks, hidden=[256, 128]),
                              in_keys=["observation", "task_id"], out_keys=["state_value"]).to(device)

    # ---- stock TorchRL collector, loss and advantage; mtbench's PCGrad on the per-task critic gradients
    frames = args.num_envs * args.horizon
    collector = Collector(env, actor, frames_per_batch=frames, total_frames=frames * args.iterations,
                          trust_policy=True, track_traj_ids=False, no_cuda_sync=device.type == "cuda",
                          auto_register_policy_transforms=False)
    loss = ClipPPOLoss(actor, critic, clip_epsilon=0.2, entropy_coeff=0.005, critic_coeff=2.0,
                       loss_critic_type="l2")
    loss.make_value_estimator(GAE(gamma=0.99, lmbda=0.95, value_network=critic, auto_reset_env=True,
                                  average_gae=True, group_key="task_id"))
    update = PCGrad(loss, num_tasks)  # MTBench's PPO configs: the critic's per-task gradients are projected
    optimizer = torch.optim.Adam(loss.parameters(), lr=5e-4, eps=1e-8)
    window = EpisodeStatsWindow(base_env.task_names, window=5)

    # ---- the loop: rollout, advantage, update
    minibatch = frames // args.minibatches
    for iteration, data in enumerate(collector, start=1):
        t0 = time.perf_counter()
        with torch.no_grad():
            data = loss.value_estimator(data)
        flat = data.reshape(-1)
        for _ in range(args.epochs):
            for idx in torch.randperm(frames, device=device).split(minibatch):
                optimizer.zero_grad(set_to_none=True)
                metrics = compute_gradients(update, flat[idx])
                torch.nn.utils.clip_grad_norm_(loss.parameters(), 1.0)
                optimizer.step()
        window.push(base_env.pop_episode_stats())
        success = window.mean_success()  # NaN until an episode finished
        print(f"iteration {iteration}/{args.iterations}: {iteration * frames:,} frames, success "
              f"{'n/a' if success != success else f'{100 * success:.1f}%'}, critic loss "
              f"{float(metrics['loss_critic']):.3f}, update {time.perf_counter() - t0:.1f} s", flush=True)
    collector.shutdown()
    print(f"\nPer-task success over the last {window.window} iterations:")
    print(window.table(), flush=True)
    return window


if __name__ == "__main__":
    main()
