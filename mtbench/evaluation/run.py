"""Glue behind ``examples/eval.py``: checkpoint -> env + policy -> sampled / deterministic evaluations -> reports,
videos and the MCAP log."""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import torch
from omegaconf import DictConfig, OmegaConf

from ..trainer.metrics import END_PREFIX
from .args import EvalArgs, EvalArgumentError, parse_args
from .episodes import EvalResult, fewest_worlds, passes_needed, run_episodes, worlds_per_task
from .policy import EvalPolicy, checkpoint_num_tasks, load_policy, make_eval_env, read_checkpoint
from .report import report_tables, write_reports
from .task_slots import task_slots
from .video import VideoRecorder, contact_sheet, write_png, write_video

DEFAULT_VIDEO_FRAMES = 150
VIDEO_SIZE_CUDA = (320, 240)
VIDEO_SIZE_CPU = (160, 120)
SHEET_COLUMNS = 7  # frames per row of videos/frames.png


@dataclasses.dataclass
class EvalReport:
    """What an evaluation produced: the results (sampled first, if run), the table and the written files."""

    results: list[EvalResult]
    table: str
    out: Path
    markdown: Path
    json: Path
    mcap: Path | None
    videos: dict[str, Path]
    frames_png: Path | None
    info: dict[str, Any]


#: seconds between two progress lines of a long evaluation pass (stderr)
PROGRESS_EVERY_S = 15.0


def video_schedule(steps: int, frames: int | None = None, every: int | None = None) -> tuple[int, int]:
    """``(frames, every)`` of the videos of ``steps``-step episodes: every ``every``-th step is recorded, ``frames``
    of them. Defaults: the whole episode in at most ``DEFAULT_VIDEO_FRAMES`` frames (``every`` 1 where ``frames`` is
    given). Raises ``EvalArgumentError`` naming ``video_frames`` / ``video_every`` and their range."""
    if every is None:
        every = 1 if frames is not None else math.ceil(steps / DEFAULT_VIDEO_FRAMES)
    if not 1 <= every <= steps:
        raise EvalArgumentError(f"video_every={every} is out of range; video_every must be an integer in [1, {steps}] "
                                f"(the episode length)")
    most = math.ceil(steps / every)
    frames = min(DEFAULT_VIDEO_FRAMES, most) if frames is None else frames
    if not 1 <= frames <= most:
        where = ("(the episode length)" if every == 1
                 else f"(the episode length {steps} / video_every {every}, rounded up)")
        raise EvalArgumentError(f"video_frames={frames} is out of range; video_frames must be an integer in "
                                f"[1, {most}] {where}")
    return frames, every


def with_env_overrides(env_cfg: DictConfig, overrides: Sequence[str]) -> DictConfig:
    """The run's ``env`` config with ``env.name=...`` / ``env.overrides.<key>=...`` items merged in (Hydra-style
    values: ``[a,b]`` lists, booleans, numbers, ``null``)."""
    try:
        change = OmegaConf.from_dotlist([item[len("env."):] for item in overrides])
    except Exception as err:  # omegaconf's grammar errors
        raise EvalArgumentError(f"cannot read the env overrides {list(overrides)}: {err}") from None
    return OmegaConf.merge(env_cfg, change)


def _device(name: str) -> torch.device:
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(name)


def _log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def evaluate(args: EvalArgs, *, policy_hook: Callable[[EvalPolicy], None] | None = None,
             logger: str = "mcap") -> EvalReport:
    """Evaluate the checkpoint of ``args`` (see :class:`~mtbench.evaluation.args.EvalArgs`); writes
    ``eval.md``, ``eval.json``, ``eval.mcap`` (``logger="mcap"``; ``"none"`` skips it) and, with ``video``,
    ``videos/<task>.mp4|gif`` and ``videos/frames.png`` into ``args.out``. ``policy_hook`` may modify the loaded
    policy before the evaluation (tests)."""
    state = read_checkpoint(args.checkpoint)
    cfg = OmegaConf.create(state["config"])
    device = _device(args.device)
    if cfg.get("torch_threads"):
        torch.set_num_threads(int(cfg.torch_threads))
    num_tasks = checkpoint_num_tasks(state)
    slots = None
    if args.env_overrides:
        trained_on = cfg.env.name
        cfg.env = with_env_overrides(cfg.env, args.env_overrides)
        if "env.name" in {o.split("=", 1)[0] for o in args.env_overrides}:  # the tasks of the new env
            name = cfg.env.name
            slots = task_slots(trained_on, name)  # a Meta-World subset: the env's tasks -> the policy's slots
            num_tasks = len(slots.slots) if slots is not None else len(name) if OmegaConf.is_list(name) else None
    num_envs = args.num_envs
    if num_envs is None:
        if num_tasks is None:
            why = ("the number of tasks of env.name={} is not known before the env is built".format(cfg.env.name)
                   if args.env_overrides else "the checkpoint does not record its number of tasks")
            raise EvalArgumentError(f"num_envs must be given: {why}")
        num_envs = args.episodes * num_tasks
    elif num_tasks is not None and num_envs < num_tasks:
        raise EvalArgumentError(f"num_envs={num_envs} is smaller than the number of tasks ({num_tasks}); num_envs "
                                f"must be an integer >= {num_tasks}")
    seed = args.seed if args.seed is not None else int(cfg.get("seed", 0)) + 1
    out = args.out if args.out is not None else Path(args.checkpoint).resolve().parent / "eval"

    t0 = time.perf_counter()
    env = make_eval_env(cfg.env, num_envs, device, seed)
    try:
        policy = load_policy(state, env, device, task_slots=slots)
        if policy_hook is not None:
            policy_hook(policy)
        steps = int(env.max_episode_steps)
        counts = worlds_per_task(env)
        recorder = None
        if args.video and getattr(env, "blocks", None) is None and getattr(env, "sim", None) is None:
            raise EvalArgumentError(f"video=true renders envs simulated by MuJoCo Warp (Meta-World, Parkour); "
                                    f"{type(env).__name__} has no simulator to render: run with video=false")
        if args.video:
            frames, every = video_schedule(steps, args.video_frames, args.video_every)
            fewest = fewest_worlds(env)
            if args.video_grid ** 2 > fewest:
                raise EvalArgumentError(
                    f"video_grid={args.video_grid} needs {args.video_grid ** 2} worlds per task, the smallest task "
                    f"block has {fewest}; use video_grid=1 or more episodes / num_envs"
                )
            width, height = args.video_size or (VIDEO_SIZE_CUDA if device.type == "cuda" else VIDEO_SIZE_CPU)
            recorder = VideoRecorder(env, frames, width, height, grid=args.video_grid, every=every)
        metric = str(getattr(env, "success_metric", "success"))
        info: dict[str, Any] = {
            "checkpoint": str(Path(args.checkpoint).resolve()),
            "env": OmegaConf.to_container(cfg.env.name) if OmegaConf.is_config(cfg.env.name) else cfg.env.name,
            "arch": cfg.get("arch", {}).get("name"),
            "loss": cfg.get("loss", {}).get("name"),
            "iteration": int((state.get("counters") or {}).get("iteration", 0)),
            "frames": int((state.get("counters") or {}).get("frames", 0)),
            "device": str(device),
            "num_envs": int(sum(counts)),
            "worlds_per_task": counts,
            "seed": seed,
            "episodes_requested": args.episodes,
            "episode_steps": steps,
            "passes": passes_needed(env, args.episodes),
            "metric": metric,
            "task_names": list(env.task_names),
            "env_overrides": list(args.env_overrides),
        }
        _log(f"eval | {info['env']} | {len(counts)} tasks x {counts} worlds | {info['passes']} pass(es) of {steps} "
             f"steps | device {device} | seed {seed} | env ready in {time.perf_counter() - t0:.1f}s")
        results = []
        modes = [True] if args.deterministic else [False, True]
        for deterministic in modes:
            t1 = time.perf_counter()

            shown = [t1]
            passes = info["passes"]

            def on_step(p: int, t: int, finished: torch.Tensor, record: bool = deterministic,
                        label: str = "deterministic" if deterministic else "sampled") -> None:
                if record and recorder is not None and p == 0:
                    recorder.capture(t, finished)
                now = time.perf_counter()
                if t > 0 and now - shown[0] >= PROGRESS_EVERY_S:  # a line every PROGRESS_EVERY_S on long passes
                    shown[0] = now
                    done = (p * steps + t) / (passes * steps)
                    _log(f"eval | {label}: pass {p + 1}/{passes}, step {t}/{steps} "
                         f"({100 * done:.0f}%), {now - t1:.0f}s, ~{(now - t1) * (1 - done) / done:.0f}s left")

            result = run_episodes(env, policy, episodes=args.episodes, deterministic=deterministic, seed=seed,
                                  on_step=on_step)
            results.append(result)
            _log(f"eval | {result.mode}: mean {metric} {100 * result.mean_success:.1f}% over "
                 f"{sum(result.episodes)} episodes ({time.perf_counter() - t1:.1f}s)")
            for key, values in result.extra.items():  # e.g. worlds reset after a physics failure
                if key.startswith(END_PREFIX):  # how the episodes ended: a table of the report
                    continue
                counts = {name: v for name, v in zip(result.task_names, values) if v > 0}
                if counts:
                    _log(f"eval | {result.mode}: {key} per task {counts}")
        videos: dict[str, Path] = {}
        frames_png = None
        clips = None
        if recorder is not None:
            clips = recorder.videos()
            names = [env.task_names[i] for i in recorder.task_ids]
            for name, clip in zip(names, clips):
                videos[name] = write_video(out / "videos" / name, clip, args.video_fps)
            middle = clips.shape[1] // 2
            labels = [f"{name} (step {middle * recorder.every})" for name in names]
            sheet = contact_sheet(list(clips[:, middle].numpy()), labels, columns=min(len(labels), SHEET_COLUMNS))
            frames_png = write_png(out / "videos" / "frames.png", sheet)
            info["videos"] = {k: str(v) for k, v in videos.items()}
            info["video"] = {"frames": int(clips.shape[1]), "every": recorder.every,
                             "size": list(clips.shape[2:4][::-1]),
                             "grid": args.video_grid, "fps": args.video_fps, "policy": "deterministic",
                             "episode": "first of each of the first worlds of every task block"}
    finally:
        close = getattr(env, "close", None)
        if callable(close):
            close()
    table = report_tables(results)
    md, js = write_reports(out, results, info)
    mcap = _write_mcap(out, results, info, cfg, args, clips) if logger == "mcap" else None
    return EvalReport(results=results, table=table, out=out, markdown=md, json=js, mcap=mcap, videos=videos,
                      frames_png=frames_png, info=info)


def _write_mcap(out: Path, results: list[EvalResult], info: dict[str, Any], cfg: Any, args: EvalArgs,
                clips: torch.Tensor | None) -> Path:
    """``out/eval.mcap``: the results as scalars at step = the checkpoint's training frames (``success/<task>``,
    ``return/<task>``, ``length/<task>``, ``success/mean``, ``return/mean``, and with end reasons
    ``end_<reason>/<task>`` (shares of the episodes) for the sampled evaluation, the same
    under ``deterministic/`` for the deterministic one), the configuration as hyperparameters, and the videos on
    ``/video/eval/<task>``."""
    from ..logging import MCAPLogger

    logger = MCAPLogger("eval", log_dir=str(out), if_exists="overwrite", flush_interval_s=None)
    try:
        eval_args = {k: (str(v) if isinstance(v, Path) else v) for k, v in dataclasses.asdict(args).items()}
        logger.log_hparams({"eval": {**eval_args, "seed": info["seed"], "num_envs": info["num_envs"]},
                            "run": OmegaConf.to_container(cfg, resolve=True)})
        step = info["frames"]
        for r in results:
            prefix = "" if r.mode == "sampled" else "deterministic/"
            metrics: dict[str, float] = {}
            ends = r.end_shares()
            for i, name in enumerate(r.task_names):
                if r.episodes[i] > 0:
                    metrics[f"{prefix}success/{name}"] = r.success[i]
                    metrics[f"{prefix}return/{name}"] = r.returns[i]
                    metrics[f"{prefix}length/{name}"] = r.lengths[i]
                    for reason, shares in ends.items():
                        metrics[f"{prefix}end_{reason}/{name}"] = shares[i]
                metrics[f"{prefix}episodes/{name}"] = float(r.episodes[i])
            metrics[f"{prefix}success/mean"] = r.mean_success
            metrics[f"{prefix}return/mean"] = r.mean_return
            logger.log_metrics(metrics, step=step)
        if clips is not None:
            for name, clip in zip(info["task_names"], clips):
                logger.log_video(f"eval/{name}", clip, step=step, fps=args.video_fps)
    finally:
        logger.close()
    return out / "eval.mcap"


def main(argv: Sequence[str] | None = None) -> int:
    """``python examples/eval.py key=value ...``: prints the table and the written paths; exit status 2 with a
    message naming the parameter on a bad argument."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if any(a in ("-h", "--help", "help") for a in argv):
        from .args import USAGE

        print(USAGE)
        return 0
    try:
        report = evaluate(parse_args(argv))
    except EvalArgumentError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"\nPer-task evaluation ({report.info['metric']}: {report.info['metric']} at any step of the episode; "
          "sampled = actions drawn from the policy as in training, deterministic = the Gaussian mean, or the greedy "
          "action of a Q network):\n")
    print(report.table)
    print(f"\nwrote {report.markdown}, {report.json}" + (f", {report.mcap}" if report.mcap else ""))
    for name, path in report.videos.items():
        print(f"video {name}: {path}")
    if report.frames_png is not None:
        print(f"frames: {report.frames_png}")
    return 0


__all__ = ["DEFAULT_VIDEO_FRAMES", "EvalReport", "evaluate", "main", "video_schedule"]
