"""GPU correctness check of the CUDA-graphed minibatch update (``cudagraph_update``) for every gradient method:
the graphed update against the eager one from the same state.

    python benchmarks/update_check.py                                   # cuda, MT-PPO, grad none pcgrad cagrad famo
    python benchmarks/update_check.py --grads pcgrad --arch moore --matmul-precision high
    python benchmarks/update_check.py --loss pqn --arch residual_mlp    # MT-PQN: capturable RAdam, found_inf skip
    python benchmarks/update_check.py --device cpu --num-envs 16 --minibatch-size 128   # plumbing only
    python benchmarks/update_check.py --loss sac --grads none pcgrad    # MT-SAC: the draw from the full buffer
    python benchmarks/update_check.py --loss sac --device cpu --num-envs 16 --grads none --minibatch-size 32
    python benchmarks/update_check.py --grads none famo --epochs 3 --override loss.lr_schedule=adaptive  # KL reference

For each gradient method the real training stack is built (``conf/`` + ``build_trainer``, ``--loss`` on ``--env``),
one rollout is collected and its advantages (PQN: Peng's Q(lambda) targets) computed; then, from one saved state
(networks, value normaliser, optimizer, gradient-method state such as FAMO's logits or PCGrad's generator, the
CUDA RNG that draws the minibatch permutation), ``--epochs`` epochs of minibatch updates are run three times:
with the graphed update (3 eager warm-up minibatches, the capture, then replays), eagerly, and eagerly again.
The eager-vs-eager difference measures the run-to-run nondeterminism of the GPU (float atomics in
``index_add``/``scatter``); the check passes when the graphed run's largest parameter difference from the eager run
is at most ``max(4 x eager-vs-eager, --atol)``.
On a CPU nothing is captured (graphed = eager), so every difference must be exactly 0.

``--loss sac`` (:func:`check_sac`): the replay buffer (``--replay-iterations`` x ``num_envs`` transitions) is filled
by iterations of the real loop (warm-up, then eager updates), then from one saved state (networks, temperatures,
target networks, optimizer, gradient-method state, CUDA RNG: it draws the replay indices and SAC's actions)
``--steps`` updates run through ``trainer.update`` with the graphed draw-and-update (3 eager warm-ups, the capture,
replays) and eagerly (TorchRL's sampler, the same indices), twice; the same criterion, over the parameters, the
temperatures and the target networks (``--minibatch-size``: ``loss.batch_size``, default 8192).
"""

from __future__ import annotations

import argparse
import copy
import sys
import tempfile
from pathlib import Path

import torch
from hydra import compose, initialize_config_dir

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mtbench.trainer import build_trainer, resolve_device  # noqa: E402
from mtbench.trainer.update import MinibatchUpdate  # noqa: E402

GRADS = ("none", "pcgrad", "cagrad", "famo")
#: minibatch size per loss when --minibatch-size is not given (PPO: 4096 worlds x 32 steps / 16384 = 8 updates an
#: epoch; PQN: 4096 x 16 / 4096 = 16, so that the graph is replayed many times after its 3 warm-up updates)
DEFAULT_MINIBATCH = {"ppo": 16384, "grpo": 16384, "pqn": 4096, "sac": 8192}


def _state(trainer) -> dict:
    """Everything one epoch of updates reads and changes (deep copies)."""
    dev = trainer.updater.device
    return {
        "loss": copy.deepcopy(trainer.loss.state_dict()),
        "module": copy.deepcopy(trainer.updater.update_module.state_dict()),
        "optimizer": copy.deepcopy(trainer.optimizer.state_dict()),
        "rng": torch.cuda.get_rng_state(dev) if dev.type == "cuda" else torch.get_rng_state(),
    }


def _restore(trainer, state: dict) -> None:
    dev = trainer.updater.device
    trainer.loss.load_state_dict(state["loss"])
    trainer.updater.update_module.load_state_dict(state["module"])
    trainer.optimizer.load_state_dict(copy.deepcopy(state["optimizer"]))  # the lr tensor is changed in place
    if dev.type == "cuda":
        torch.cuda.set_rng_state(state["rng"], dev)
    else:
        torch.set_rng_state(state["rng"])


def _params(trainer) -> list[torch.Tensor]:
    return [p.detach().clone() for p in trainer.loss.parameters() if p.requires_grad]


def _max_diff(a: list[torch.Tensor], b: list[torch.Tensor]) -> float:
    return max(float((x - y).abs().max()) for x, y in zip(a, b, strict=True))


def _report(ok: bool, what: str, d_graph: float, d_eager: float, moved: float, loss_key: str, means_g: dict,
            means_e: dict, extra: str = "") -> None:
    print(f"{'PASS' if ok else 'FAIL'} {what}: max |param graphed - eager| {d_graph:.3e}, eager - eager "
          f"{d_eager:.3e}, max update {moved:.3e}; mean {loss_key} graphed {float(means_g[loss_key]):.6f} eager "
          f"{float(means_e[loss_key]):.6f}{extra}", flush=True)


def check_sac(grad: str, args: argparse.Namespace, device: torch.device, overrides: list[str]) -> bool:
    """The graphed MT-SAC update (draw from the full buffer + step) against the eager one (see the module doc)."""
    capacity = args.replay_iterations * args.num_envs
    overrides = [o for o in overrides if not o.startswith(("loss.minibatch_size=", "max_iterations="))]
    overrides += [f"loss.batch_size={args.minibatch_size or DEFAULT_MINIBATCH['sac']}",
                  f"loss.replay_buffer_size={capacity}", f"max_iterations={args.replay_iterations + 8}"]
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    trainer = build_trainer(cfg)
    while not trainer.replay_full():  # warm-up iterations, then eager updates while the buffer fills
        trainer.train_iteration()
    graphed = trainer.updater
    start = _state(trainer)

    def everything() -> list[torch.Tensor]:  # parameters, log_alpha, target Q networks
        return [t.detach().clone().float() for t in trainer.loss.state_dict().values()]

    before = everything()
    means_g = trainer.update(args.steps)
    after_graph = everything()
    captured = graphed._drawn_stage.captured
    eager_runs = []
    for _ in range(2):
        _restore(trainer, start)
        trainer.updater = MinibatchUpdate(graphed.update_module, trainer.optimizer, max_grad_norm=graphed.max_grad_norm,
                                          clip_groups=graphed.clip_groups, call_hooks=graphed.call_hooks,
                                          after_step=graphed.after_step, graph=False, device=graphed.device)
        means_e = trainer.update(args.steps)
        eager_runs.append(everything())
    trainer.env.close()
    moved, d_graph = _max_diff(after_graph, before), _max_diff(after_graph, eager_runs[0])
    d_eager = _max_diff(eager_runs[1], eager_runs[0])
    ok = all(torch.isfinite(t).all().item() for t in after_graph) and d_graph <= max(4.0 * d_eager, args.atol)
    _report(ok, f"loss=sac grad={grad} arch={args.arch} matmul_precision={args.matmul_precision} graphed={captured} "
                f"updates={args.steps} buffer={capacity:,}", d_graph, d_eager, moved, "loss_qvalue", means_g, means_e)
    return bool(ok)


def check(grad: str, args: argparse.Namespace, device: torch.device) -> bool:
    minibatch_size = args.minibatch_size or DEFAULT_MINIBATCH[args.loss]
    overrides = [
        f"env.name={args.env}", f"env.num_envs={args.num_envs}", f"loss={args.loss}", f"arch={args.arch}",
        f"grad={grad}",
        f"device={device}", "seed=0", "max_iterations=1", f"matmul_precision={args.matmul_precision}",
        f"cudagraph_update={str(device.type == 'cuda').lower()}", "logging.logger=none", "logging.progress=none",
        "checkpoint.every=0", "checkpoint.save_final=false", f"checkpoint.dir={tempfile.mkdtemp(prefix='mtbench-check-')}",
        f"loss.minibatch_size={minibatch_size}",
    ]
    if args.diagnostics_every is not None:  # else the grad preset's (measured between graph replays)
        overrides.append(f"grad.diagnostics_every={args.diagnostics_every}")
    overrides += list(args.override)
    if args.loss == "sac":
        return check_sac(grad, args, device, overrides)
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    trainer = build_trainer(cfg)
    graphed = trainer.updater
    data, _ = trainer.collect()
    flat = trainer.advantage(data).exclude("next").reshape(-1)
    start = _state(trainer)
    before = _params(trainer)

    # each run on its own copy of the batch: with loss.lr_schedule_type=standard the update rewrites its loc/scale
    means_g, count = graphed.epochs(flat.clone(), args.epochs, trainer.minibatch_size)
    after_graph = _params(trainer)
    eager_runs = []
    for _ in range(2):
        _restore(trainer, start)
        eager = MinibatchUpdate(graphed.update_module, trainer.optimizer, max_grad_norm=graphed.max_grad_norm,
                                call_hooks=graphed.call_hooks, graph=False, device=graphed.device,
                                kl_reference=graphed.kl_reference)
        means_e, _ = eager.epochs(flat.clone(), args.epochs, trainer.minibatch_size)
        eager_runs.append(_params(trainer))
    trainer.env.close()

    moved = _max_diff(after_graph, before)
    d_graph = _max_diff(after_graph, eager_runs[0])
    d_eager = _max_diff(eager_runs[1], eager_runs[0])
    loss_key = "loss_critic" if "loss_critic" in means_g else next(iter(means_g))
    # the gradient diagnostics (measured between replays when graphed, inside backward when eager) must agree too
    cos_keys = [k for k in means_g if k.startswith("grad_cos_")]
    d_cos = max((abs(float(means_g[k]) - float(means_e[k])) for k in cos_keys), default=0.0)
    ok = torch.isfinite(torch.stack([p.float().abs().max() for p in after_graph])).all().item() and (
        d_graph <= max(4.0 * d_eager, args.atol)
    ) and d_cos <= 1e-3
    _report(ok, f"loss={args.loss} grad={grad} arch={args.arch} matmul_precision={args.matmul_precision} "
                f"linalg={args.linalg or 'default'} graphed={graphed.graph and graphed._stage.captured} "
                f"minibatches={count}", d_graph, d_eager, moved, loss_key, means_g, means_e,
            f"; diagnostics {len(cos_keys)} keys, max |graphed - eager| {d_cos:.2e}" if cos_keys else "")
    return bool(ok)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--grads", nargs="*", default=list(GRADS), help=f"gradient methods (of {list(GRADS)})")
    p.add_argument("--arch", default="mlp", help="conf/arch preset")
    p.add_argument("--env", default="mt10_rand")
    p.add_argument("--num-envs", type=int, default=4096)
    p.add_argument("--loss", default="ppo", choices=list(DEFAULT_MINIBATCH),
                   help="conf/loss preset (pqn: RAdam with capturable=True, the non-finite guard's found_inf)")
    p.add_argument("--minibatch-size", type=int, default=None,
                   help=f"1 epoch = num_envs * horizon / this minibatches (default per loss: {DEFAULT_MINIBATCH})")
    p.add_argument("--epochs", type=int, default=1, help="epochs of minibatch updates compared")
    p.add_argument("--steps", type=int, default=8, help="--loss sac: updates compared (3 of them graph warm-ups)")
    p.add_argument("--replay-iterations", type=int, default=8,
                   help="--loss sac: replay buffer of this many iterations x num_envs transitions")
    p.add_argument("--matmul-precision", default="highest", choices=["highest", "high", "medium"])
    p.add_argument("--atol", type=float, default=1e-5, help="parameter tolerance when eager runs agree exactly")
    p.add_argument("--diagnostics-every", type=int, default=None,
                   help="override grad.diagnostics_every (default: the grad preset's; 1 = measure before every update)")
    p.add_argument("--device", default="cuda")
    p.add_argument("--override", action="append", default=[],
                   help="extra Hydra override, repeatable (e.g. loss.lr_schedule=adaptive: the KL reference of "
                        "loss.lr_schedule_type=standard, written back by the graphed update)")
    p.add_argument("--linalg", default=None, choices=["default", "cusolver", "magma"],
                   help="torch.backends.cuda.preferred_linalg_library (CAGrad's KKT solve: lu_factor / lu_solve)")
    args = p.parse_args(argv)
    if args.linalg is not None:
        torch.backends.cuda.preferred_linalg_library(args.linalg)
    unknown = sorted(set(args.grads) - set(GRADS))
    if unknown:
        raise ValueError(f"--grads: unknown {unknown}; valid choices: {list(GRADS)}")
    device = resolve_device(args.device)
    results = {}
    for grad in args.grads:
        try:
            results[grad] = check(grad, args, device)
        except Exception as err:  # report and go on with the next method
            print(f"FAIL grad={grad}: {type(err).__name__}: {err}", flush=True)
            results[grad] = False
    print("update_check:", "ALL PASS" if all(results.values()) else f"FAILED {[g for g, ok in results.items() if not ok]}")


if __name__ == "__main__":
    main()
