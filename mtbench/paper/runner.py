"""``python -m mtbench.paper run``: launch the rows x seeds of a table as ``examples/train.py`` subprocesses.

One run directory per (row, seed): ``<out>/<row>/s<seed>/`` holding the MCAP log ``<table>-<row>-s<seed>.mcap``,
``checkpoints/`` (``final.pt``, ``last.pt``), Hydra's ``.hydra/`` and ``train.log``, the subprocess output
``train.out`` and, once the run has finished, the marker ``done.json`` (the frames it was asked for). A run is

* ``done``: ``done.json`` exists for at least the frames asked now -> skipped;
* ``resume``: ``checkpoints/last.pt`` exists -> continued from it (``resume=``; the MCAP log gets a new segment);
  a finished run asked for more frames continues from its final checkpoint the same way;
* ``new``: otherwise (partial MCAP files of a run killed before its first checkpoint are removed first);
* ``blocked``: a Parkour row whose flat-ground pre-training run (same seed) has no ``final.pt``.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .rows import CONF_DIR, REPO_ROOT, Row, group_overrides

__all__ = ["Launch", "command", "execute", "plan_runs", "run_dir", "DONE_MARKER"]

DONE_MARKER = "done.json"


def run_dir(out: Path, row: str, seed: int) -> Path:
    return Path(out) / row / f"s{seed}"


def exp_name(row: Row, seed: int) -> str:
    return f"{row.table}-{row.name}-s{seed}"


def read_marker(directory: Path) -> dict | None:
    path = Path(directory) / DONE_MARKER
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


@dataclass
class Launch:
    """One (row, seed) run: where it lives, how many frames it should reach and what to do with it."""

    row: Row
    seed: int
    directory: Path
    frames: int
    state: str = "new"  # done | resume | new | blocked | unavailable
    resume: Path | None = None
    pretrained: Path | None = None
    note: str = ""
    problems: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return f"{self.row.table}/{self.row.name} s{self.seed}"


def _state(launch: Launch, out: Path) -> None:
    """Fill ``state``/``resume``/``pretrained``/``note`` from what is on disk."""
    if launch.problems:
        launch.state, launch.note = "unavailable", "not available: " + "; ".join(launch.problems)
        return
    marker = read_marker(launch.directory)
    last = launch.directory / "checkpoints" / "last.pt"
    if marker is not None and int(marker.get("frames", 0)) >= launch.frames:
        launch.state, launch.note = "done", f"finished ({int(marker['frames']):,} frames)"
        return
    if last.exists():
        launch.state, launch.resume = "resume", last
        launch.note = ("more frames than its finished run: continues from its final checkpoint" if marker is not None
                       else "continues from its last checkpoint")
    else:
        launch.state, launch.note = "new", ""
    if launch.row.pretrain is not None:
        ckpt = run_dir(out, launch.row.pretrain, launch.seed) / "checkpoints" / "final.pt"
        launch.pretrained = ckpt
        if not ckpt.exists():
            launch.note = f"starts from {ckpt} (written by pre-training row {launch.row.pretrain}, run first)"


def plan_runs(
    rows: Sequence[Row],
    *,
    out: Path,
    seeds: int | None = None,
    frames: int | None = None,
    problems: dict[str, list[str]] | None = None,
    seed_list: Sequence[int] | None = None,
) -> list[Launch]:
    """The launches for ``rows`` x their first ``seeds`` seeds (all of the row's seeds when ``None``; ``seed_list``:
    these seeds instead), at ``frames`` per run (the row's ``total_frames`` when ``None``); pre-training rows
    first."""
    problems = problems or {}
    ordered = sorted(rows, key=lambda r: not r.is_pretrain)
    launches = []
    for row in ordered:
        chosen = row.seeds if seeds is None else row.seeds[:seeds]
        if seed_list is not None:
            chosen = list(seed_list)
        elif seeds is not None and seeds > len(row.seeds):  # more seeds than the paper's list: continue it
            chosen = row.seeds + list(range(max(row.seeds) + 1, max(row.seeds) + 1 + seeds - len(row.seeds)))
        for seed in chosen:
            launch = Launch(row, seed, run_dir(out, row.name, seed), int(frames or row.frames),
                            problems=list(problems.get(row.name, [])))
            _state(launch, out)
            launches.append(launch)
    return launches


def command(
    launch: Launch,
    *,
    conf_dir: Path = CONF_DIR,
    extra: Sequence[str] = (),
    python: str = sys.executable,
) -> list[str]:
    """The ``examples/train.py`` command line of ``launch`` (absolute paths; run it from the repository root)."""
    row, d = launch.row, launch.directory.resolve()
    cmd = [
        python, str(Path(conf_dir).resolve().parent / "examples" / "train.py"),
        "--config-dir", str((Path(conf_dir) / "paper" / row.table).resolve()), "--config-name", row.name,
        *group_overrides(row, conf_dir),
        f"seed={launch.seed}",
        f"total_frames={launch.frames}",
        f"logging.exp_name={exp_name(row, launch.seed)}",
        f"logging.log_dir={d}",
        f"checkpoint.dir={d / 'checkpoints'}",
        f"hydra.run.dir={d}",
    ]
    if launch.resume is not None:
        cmd.append(f"resume={launch.resume.resolve()}")
    if launch.pretrained is not None:
        cmd.append(f"pretrained={launch.pretrained.resolve()}")
    cmd += list(extra)
    return cmd


def _final_success(directory: Path) -> str:
    try:
        from mtbench.logging import read_scalars

        files = sorted(directory.glob("*.mcap"))
        if not files:
            return ""
        scalars = read_scalars(files[0])
        points = scalars.get("success/mean") or []
        return f", success/mean {points[-1][1]:.3f}" if points else ""
    except Exception as err:  # a log that cannot be read must not stop the other runs
        return f", log unreadable ({type(err).__name__})"


def _display(cmd: Sequence[str], python: str) -> str:
    """The command as a user would type it from the repository root."""
    root = str(REPO_ROOT) + os.sep
    return shlex.join(["python" if c == python else c.replace(root, "") for c in cmd])


Runner = Callable[..., "subprocess.CompletedProcess[bytes]"]


def execute(
    launches: Sequence[Launch],
    *,
    conf_dir: Path = CONF_DIR,
    extra: Sequence[str] = (),
    dry_run: bool = False,
    runner: Runner | None = None,
    python: str = sys.executable,
    echo: Callable[[str], None] = lambda s: print(s, flush=True),
) -> int:
    """Run (or print, ``dry_run``) the launches in order; returns the number of runs that failed.

    ``runner(cmd, cwd=..., env=..., stdout=..., stderr=...)`` defaults to ``subprocess.run`` (tests pass a fake).
    """
    runner = runner or subprocess.run
    todo = [launch for launch in launches if launch.state in ("new", "resume")]
    failures = 0
    for i, launch in enumerate(launches, 1):
        head = f"[{i}/{len(launches)}] {launch.name}"
        if launch.state in ("done", "unavailable"):
            echo(f"{head}: {launch.state}: {launch.note}" if launch.state == "done" else f"{head}: {launch.note}")
            continue
        if launch.pretrained is not None and not launch.pretrained.exists() and not dry_run:
            launch.state = "blocked"
            echo(f"{head}: blocked: no pre-training checkpoint {launch.pretrained}")
            failures += 1
            continue
        cmd = command(launch, conf_dir=conf_dir, extra=extra, python=python)
        what = f"{launch.state} ({launch.frames:,} frames){': ' + launch.note if launch.note else ''}"
        if dry_run:
            echo(f"{head}: {what}\n    {_display(cmd, python)}")
            continue
        launch.directory.mkdir(parents=True, exist_ok=True)
        if launch.state == "new":
            for stale in launch.directory.glob("*.mcap"):  # a run killed before its first checkpoint
                echo(f"{head}: removing the partial log {stale} (no checkpoint to resume from)")
                stale.unlink()
        echo(f"{head}: {what} ...")
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(REPO_ROOT), *filter(None, [env.get("PYTHONPATH")])])
        t0 = time.time()
        with open(launch.directory / "train.out", "ab") as log:
            log.write(f"\n=== {time.strftime('%Y-%m-%d %H:%M:%S')} {shlex.join(cmd)}\n".encode())
            log.flush()
            try:
                proc = runner(cmd, cwd=str(REPO_ROOT), env=env, stdout=log, stderr=subprocess.STDOUT)
            except KeyboardInterrupt:
                echo(f"{head}: interrupted; the run keeps its last checkpoint (run the same command to resume)")
                raise
        seconds = time.time() - t0
        final = launch.directory / "checkpoints" / "final.pt"
        if proc.returncode == 0 and final.exists():
            marker = {"table": launch.row.table, "row": launch.row.name, "seed": launch.seed,
                      "frames": launch.frames, "seconds": round(seconds, 1), "command": cmd}
            (launch.directory / DONE_MARKER).write_text(json.dumps(marker, indent=1) + "\n")
            echo(f"{head}: done in {seconds:.0f} s{_final_success(launch.directory)}")
        else:
            failures += 1
            tail = ""
            try:
                tail = "\n".join((launch.directory / "train.out").read_text(errors="replace").splitlines()[-15:])
            except OSError:
                pass
            why = f"exit status {proc.returncode}" if proc.returncode else "no final checkpoint (stopped early?)"
            echo(f"{head}: FAILED after {seconds:.0f} s ({why}); log {launch.directory / 'train.out'}:\n{tail}")
    if not dry_run:
        done = sum(1 for launch in launches if read_marker(launch.directory) is not None)
        echo(f"{len(todo)} runs launched, {failures} failed; {done}/{len(launches)} finished")
    return failures
