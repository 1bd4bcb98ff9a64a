"""Command line of :mod:`mtbench.paper` (see ``docs/paper.md``).

    python -m mtbench.paper list [TABLE ...]
    python -m mtbench.paper run TABLE [--rows A,B] [--seeds N] [--frames F] [--out DIR] [--set KEY=VALUE] [--dry-run]
    python -m mtbench.paper report TABLE [--out DIR] [--docs DIR] [--reps N]

TABLE is one of the folders of ``conf/paper/`` (``mt10_rand``, ``mt50_rand``, ``parkour``, ``efficiency``,
``cosine``) or ``all``.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path

from .rows import CONF_DIR, REPO_ROOT, load_table, table_names

DEFAULT_ROOT = REPO_ROOT / "runs" / "paper"


def _frames(text: str) -> int:
    try:
        value = int(float(text))
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"--frames must be a number of frames (e.g. 2e7), got {text!r}") from err
    if value < 1:
        raise argparse.ArgumentTypeError("--frames must be >= 1")
    return value


def _tables(names: Sequence[str], conf_dir: Path) -> list[str]:
    valid = table_names(conf_dir)
    if not names or list(names) == ["all"]:
        return valid
    unknown = [n for n in names if n not in valid]
    if unknown:
        raise SystemExit(f"error: unknown table(s) {unknown}; valid choices: {valid} or all")
    return list(names)


def _out(args: argparse.Namespace, table: str, many: bool) -> Path:
    if args.out is not None:
        return Path(args.out) / table if many else Path(args.out)
    return Path(args.root) / table


def _library(conf_dir: Path):
    from .availability import Library

    return Library.current(conf_dir)


def cmd_list(args: argparse.Namespace) -> int:
    from .availability import row_problems

    lib = _library(args.conf_dir)
    for table in _tables(args.tables, args.conf_dir):
        rows = load_table(table, args.conf_dir)
        by = {r.name: r for r in rows}
        ok = 0
        lines = []
        for row in rows:
            problems = row_problems(row, lib, by)
            ok += not problems
            status = "available" if not problems else "not available: " + "; ".join(problems)
            lines.append(f"  {row.name:<28} {row.label:<26} {row.describe():<72} {row.frames:>14,} frames  {status}")
        print(f"{table}: {len(rows)} rows, {ok} available")
        print("\n".join(lines))
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from .availability import row_problems
    from .runner import execute, plan_runs

    lib = _library(args.conf_dir)
    tables = _tables([args.table], args.conf_dir)
    failures = 0
    for table in tables:
        rows_all = load_table(table, args.conf_dir)
        by = {r.name: r for r in rows_all}
        wanted = [r.strip() for r in args.rows.split(",") if r.strip()] if args.rows else list(by)
        unknown = [r for r in wanted if r not in by]
        if unknown:
            raise SystemExit(f"error: unknown rows {unknown} of table {table!r}; valid choices: {list(by)}")
        for name in list(wanted):  # pre-training rows the chosen rows start from
            pre = by[name].pretrain
            if pre is not None and pre not in wanted:
                wanted.insert(0, pre)
        rows = [by[n] for n in wanted]
        problems = {r.name: row_problems(r, lib, by) for r in rows}
        out = _out(args, table, len(tables) > 1)
        seed_list = [int(x) for x in args.seed_list.split(",") if x.strip()] if args.seed_list else None
        launches = plan_runs(rows, out=out, seeds=args.seeds, frames=args.frames, problems=problems,
                             seed_list=seed_list)
        n_ok = sum(not p for p in problems.values())
        print(f"== {table}: {len(rows)} rows ({n_ok} available) x seeds -> {len(launches)} runs under {out}"
              + (f", {args.frames:,} frames each" if args.frames else ", the paper's frames"), flush=True)
        failures += execute(launches, conf_dir=args.conf_dir, extra=args.set, dry_run=args.dry_run)
    return 1 if failures else 0


def cmd_report(args: argparse.Namespace) -> int:
    from .report import build_report

    lib = _library(args.conf_dir)
    tables = _tables([args.table], args.conf_dir)
    for table in tables:
        command = "python -m mtbench.paper " + shlex.join(["report", table, *args.extra_argv])
        path = build_report(table, out=_out(args, table, len(tables) > 1), docs_dir=args.docs,
                            conf_dir=args.conf_dir, lib=lib, reps=args.reps, command=command.strip(),
                            notes=args.note)
        print(f"wrote {path}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="python -m mtbench.paper",
                                     description="Reproduce the MTBench paper's tables from conf/paper/.")
    parser.add_argument("--conf-dir", type=Path, default=CONF_DIR, help="the conf/ folder (default: the repo's)")
    sub = parser.add_subparsers(dest="command", required=True)

    p_list = sub.add_parser("list", help="tables, rows and their availability")
    p_list.add_argument("tables", nargs="*", help="tables (default: all)")
    p_list.set_defaults(func=cmd_list)

    p_run = sub.add_parser("run", help="run the rows x seeds of a table (resumable)")
    p_run.add_argument("table", help="a table of conf/paper/ or 'all'")
    p_run.add_argument("--rows", help="comma-separated row ids (default: every row)")
    p_run.add_argument("--seeds", type=int, default=None, help="first N seeds of each row (default: the paper's 10)")
    p_run.add_argument("--seed-list", default=None, metavar="S1,S2",
                       help="explicit seeds instead of --seeds (e.g. to split one table over several processes)")
    p_run.add_argument("--frames", type=_frames, default=None,
                       help="frames per run, e.g. 2e7 (default: the paper's, the row's total_frames)")
    p_run.add_argument("--out", type=Path, default=None,
                       help="results folder of the table (default: runs/paper/<table>)")
    p_run.add_argument("--root", type=Path, default=DEFAULT_ROOT, help=argparse.SUPPRESS)
    p_run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="extra Hydra override for every run (repeatable), e.g. --set device=cuda")
    p_run.add_argument("--dry-run", action="store_true", help="print the runs and their commands, run nothing")
    p_run.set_defaults(func=cmd_run)

    p_rep = sub.add_parser("report", help="write docs/results/paper/<table>.md from the runs' MCAP logs")
    p_rep.add_argument("table", help="a table of conf/paper/ or 'all'")
    p_rep.add_argument("--out", type=Path, default=None,
                       help="results folder of the table (default: runs/paper/<table>)")
    p_rep.add_argument("--root", type=Path, default=DEFAULT_ROOT, help=argparse.SUPPRESS)
    p_rep.add_argument("--docs", type=Path, default=REPO_ROOT / "docs" / "results" / "paper",
                       help="where the markdown and PNGs go (default: docs/results/paper)")
    p_rep.add_argument("--reps", type=int, default=10_000, help="bootstrap resamples (default 10000)")
    p_rep.add_argument("--note", action="append", default=[], metavar="TEXT",
                       help="a line about the runs for the report (machine, code version, ...); repeatable")
    p_rep.set_defaults(func=cmd_report)

    args = parser.parse_args(argv)
    rest = argv[argv.index(args.table) + 1:] if getattr(args, "table", None) in argv else []
    args.extra_argv = [a for i, a in enumerate(rest) if a != "--note" and (i == 0 or rest[i - 1] != "--note")
                       and not a.startswith("--note=")]
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
