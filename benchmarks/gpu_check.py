"""GPU correctness check (run on the GPU host): TorchRL spec check, and the CUDA-graph replay of the env's torch
stages against the same stages run eagerly from the same state.

    python benchmarks/gpu_check.py mt10 256
    python benchmarks/gpu_check.py parkour_hard 1024 30

Each trial saves the full env state, takes one step with the graphs, restores the state, takes the same step
eagerly twice (restoring the state in between), and compares observation, reward and done (worlds that reset
during the step included). The physics graphs are shared by all paths, so graph-vs-eager differences come from the
torch stages or from run-to-run nondeterminism of the physics (float atomics, amplified by contacts); the second
eager step measures the latter (eager vs eager). Differences are reported separately for the worlds that reset in
the step and for the others, and per observation field. The check passes when graph vs eager is within 1e-3 (obs)
/ 1e-2 (reward), or within twice eager vs eager for the worlds that did not reset (``graphs_match``). A fourth
argument ``cpu`` runs the same check on the CPU
(no graphs of torch work there: graph vs eager is eager vs eager, and must be exactly 0). A fifth argument
``compile`` builds the Meta-World env with ``compile_stages=True``: the graphs then replay the compiled stages, and
the eager path runs the original, uncompiled code. ``group`` (after ``compile`` or alone) builds it with
``group_models=True`` (tasks whose models MuJoCo Warp can batch share one model).

    python benchmarks/gpu_check.py mt50_rand 500 20 cuda compile
    python benchmarks/gpu_check.py mt50_rand 500 20 cuda compile group
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
    device = sys.argv[4] if len(sys.argv) > 4 else "cuda"
    overrides = {"num_rows": 2} if name.startswith("parkour") else {}  # a small terrain grid is enough here
    modes = sys.argv[5:]
    unknown = set(modes) - {"compile", "group"}
    if unknown:
        raise SystemExit(f"unknown mode(s) {sorted(unknown)}; valid choices: compile, group")
    if "compile" in modes:
        overrides["compile_stages"] = True
    if "group" in modes:
        overrides["group_models"] = True
    env = make_env(name, num_envs=n, device=device, seed=0, **overrides)
    action_dim = int(env.action_spec.shape[-1])
    check_env_specs(env)
    where = torch.cuda.get_device_name() if env.device.type == "cuda" else "CPU"
    print(f"check_env_specs passed for {name} on {env.device} ({where})", flush=True)
    env.reset()
    gen = torch.Generator(device=env.device).manual_seed(1)
    for _ in range(5):  # eager warm-up steps, then the stages are captured
        env._core_step(torch.rand(n, action_dim, generator=gen, device=env.device) * 2 - 1)
    if env.device.type == "cuda":
        assert all(stage.captured for stage in env._stages), "stages were not captured"
    graph_vs_eager, eager_vs_eager = StepDiffs(env), StepDiffs(env)
    for _ in range(trials):
        state = copy.deepcopy(env.get_extra_state())
        action = torch.rand(n, action_dim, generator=gen, device=env.device) * 2 - 1
        graphed = {k: v.clone() for k, v in env._core_step(action).items() if isinstance(v, torch.Tensor)}
        after = copy.deepcopy(env.get_extra_state())
        eager = [_eager_step(env, state, action) for _ in range(2)]
        env.set_extra_state(after)  # continue from the graphed trajectory
        graph_vs_eager.add(graphed, eager[0])
        eager_vs_eager.add(eager[0], eager[1])
    print(f"graph vs eager over {trials} steps x {n} worlds: {graph_vs_eager}", flush=True)
    print(f"eager vs eager (physics run-to-run) over the same steps: {eager_vs_eager}", flush=True)
    print("largest graph-vs-eager observation differences by field:",
          _field_diffs(env, graph_vs_eager.col_diff.cpu()), flush=True)
    print("largest eager-vs-eager observation differences by field:",
          _field_diffs(env, eager_vs_eager.col_diff.cpu()), flush=True)
    td = env.rollout(200, break_when_any_done=False)
    # TorchRL marks the ("next", "observation") of autoreset steps as unknown (NaN); every observation the
    # policy sees is in "observation"
    not_done = ~td["next", "done"].squeeze(-1)
    finite = bool(torch.isfinite(td["observation"]).all()) and bool(
        torch.isfinite(td["next", "observation"][not_done]).all())
    print("rollout reward mean", td["next", "reward"].mean().item(), "finite", finite,
          "stats", {k: v.tolist() for k, v in env.pop_episode_stats().items()})
    ok = graphs_match(graph_vs_eager, eager_vs_eager) and finite
    print("GPU CHECK", "PASSED" if ok else "FAILED")
    sys.exit(0 if ok else 1)


def graphs_match(graph_vs_eager: "StepDiffs", eager_vs_eager: "StepDiffs", obs_tol: float = 1e-3,
                 reward_tol: float = 1e-2) -> bool:
    """The graphed step equals the eager one: no done mismatch, the worlds that reset within ``obs_tol`` (their
    state comes from the torch stages alone), and the others within ``obs_tol`` / ``reward_tol`` or, when the
    physics itself is not reproducible run to run (contacts amplify float-atomic ordering), within twice the
    eager-vs-eager difference of the same steps."""
    g, e = graph_vs_eager, eager_vs_eager
    return (g.done_mismatch == 0 and g.worst_obs_reset < obs_tol
            and g.worst_obs <= max(obs_tol, 2.0 * e.worst_obs) and g.worst_rew <= max(reward_tol, 2.0 * e.worst_rew))


def _eager_step(env, state: dict, action: torch.Tensor) -> dict[str, torch.Tensor]:
    """One step from ``state`` with the torch stages run eagerly, uncompiled (the outputs cloned)."""
    env.set_extra_state(copy.deepcopy(state))
    enabled = [stage.enabled for stage in env._stages]
    fns = [stage.fn for stage in env._stages]
    apply = getattr(env, "_apply_reset_samples", None)
    for stage in env._stages:
        stage.enabled = False
        stage.fn = _uncompiled(stage.fn)
    if apply is not None:
        env._apply_reset_samples = _uncompiled(apply)
    try:
        out = env._core_step(action)
        return {k: v.clone() for k, v in out.items() if isinstance(v, torch.Tensor)}
    finally:
        for stage, was, fn in zip(env._stages, enabled, fns):
            stage.enabled, stage.fn = was, fn
        if apply is not None:
            env._apply_reset_samples = apply


def _uncompiled(fn):
    """The function that ``torch.compile`` wrapped (``fn`` itself if it is not compiled)."""
    return getattr(fn, "_torchdynamo_orig_callable", fn)


class StepDiffs:
    """Largest differences between two versions of the same steps: observation (all worlds, worlds that reset in
    the step, the others), reward, done mismatches, and the per-column maximum of the observation difference."""

    def __init__(self, env) -> None:
        self.col_diff = torch.zeros(env.observation_spec["observation"].shape[-1], device=env.device)
        self.worst_obs = self.worst_obs_reset = self.worst_obs_running = self.worst_rew = 0.0
        self.done_mismatch = self.resets = 0

    def add(self, a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> None:
        diff = (a["observation"] - b["observation"]).abs()
        reset = a["done"].reshape(-1).bool()
        self.col_diff = torch.maximum(self.col_diff, diff.amax(0))
        self.worst_obs = max(self.worst_obs, float(diff.max()))
        if bool(reset.any()):
            self.worst_obs_reset = max(self.worst_obs_reset, float(diff[reset].max()))
        if bool((~reset).any()):
            self.worst_obs_running = max(self.worst_obs_running, float(diff[~reset].max()))
        self.worst_rew = max(self.worst_rew, float((a["reward"] - b["reward"]).abs().max()))
        self.done_mismatch += int((a["done"] != b["done"]).sum())
        self.resets += int(reset.sum())

    def __str__(self) -> str:
        return (f"max |d obs| {self.worst_obs:.3e} (worlds that reset: {self.worst_obs_reset:.3e}, others: "
                f"{self.worst_obs_running:.3e}; {self.resets} resets), max |d reward| {self.worst_rew:.3e}, done "
                f"mismatches {self.done_mismatch}")


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
