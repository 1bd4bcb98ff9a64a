"""``python -m mtbench.paper report <table>``: the table from the runs' MCAP logs, the paper's numbers beside ours,
learning curves with CI bands and the observations, as ``docs/results/paper/<table>.md`` + PNGs in
``docs/results/paper/<table>/``.

Per row: the final score of each seed (:mod:`mtbench.paper.results`), aggregated over seeds as mean and IQM with
95 % stratified bootstrap CIs (:mod:`mtbench.paper.stats`, rliable), the paper's value with its CI (or std), and
ours minus the paper's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .availability import Library, row_problems
from .observations import plot_curves, plot_o1, plot_o3, plot_o4
from .paper_results import PAPER_NOTES, PAPER_TABLES, PaperValue, paper_value
from .results import RETURN_KEY, SUCCESS_KEY, RunResult, load_runs
from .rows import CONF_DIR, REPO_ROOT, Row, load_table
from .stats import DEFAULT_REPS, Estimate, interval_estimates

__all__ = ["RowResult", "build_report", "row_results", "DOCS_DIR"]

DOCS_DIR = REPO_ROOT / "docs" / "results" / "paper"


@dataclass
class RowResult:
    """One row: its runs, availability and aggregate scores."""

    row: Row
    runs: list[RunResult]
    problems: list[str]
    scores: dict[str, dict[str, Estimate]] = field(default_factory=dict)  # metric -> {"mean", "iqm"}
    std: dict[str, float] = field(default_factory=dict)
    seeds: dict[str, int] = field(default_factory=dict)

    @property
    def available(self) -> bool:
        return not self.problems


def _metric_keys(row: Row) -> dict[str, tuple[str, float]]:
    """Report metric -> (logged scalar, scale): success/progress in %, return as logged."""
    main = "progress" if row.metric == "progress" else "success"
    keys = {main: (SUCCESS_KEY, 100.0)}
    if main == "success":
        keys["return"] = (RETURN_KEY, 1.0)
    return keys


def row_results(rows: Sequence[Row], out: Path, lib: Library | None, *, reps: int = DEFAULT_REPS) -> list[RowResult]:
    """Load every row's runs under ``out/<row>/`` and aggregate them."""
    by_name = {r.name: r for r in rows}
    results = []
    for row in rows:
        problems = row_problems(row, lib, by_name) if lib is not None else []
        res = RowResult(row, load_runs(Path(out) / row.name), problems)
        for metric, (key, scale) in _metric_keys(row).items():
            finals = np.asarray([r.final(key) for r in res.runs], dtype=np.float64) * scale
            finals = finals[np.isfinite(finals)]
            if len(finals):
                res.scores[metric] = interval_estimates(finals, reps=reps)
                res.std[metric] = float(np.std(finals, ddof=1)) if len(finals) > 1 else 0.0
                res.seeds[metric] = len(finals)
        results.append(res)
    return results


def _fmt_frames(n: float | None) -> str:
    if n is None or not math.isfinite(n) or n <= 0:
        return "–"
    for unit, div in (("B", 1e9), ("M", 1e6), ("k", 1e3)):
        if n >= div:
            return f"{n / div:.3g}{unit}"
    return f"{n:.0f}"


def _paper_cell(value: PaperValue | None) -> str:
    return "–" if value is None else str(value)


def _status(res: RowResult, out: Path) -> str:
    if res.problems:
        return "not available: " + "; ".join(res.problems)
    if not res.runs:
        return f"no runs under `{_rel(out / res.row.name)}`"
    done = sum(r.finished for r in res.runs)
    return f"{done}/{len(res.runs)} runs finished"


def _metric_table(results: Sequence[RowResult], table: str, metric: str, unit: str, std_col: bool) -> list[str]:
    head = ["row", f"paper {unit}", "ours mean [95% CI]", "ours IQM [95% CI]"]
    if std_col:
        head.append("ours mean ± std")
    head += ["ours − paper", "seeds", "frames/run"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for res in results:
        pv = paper_value(table, res.row.name, metric)
        est = res.scores.get(metric)
        if est is None and pv is None:
            continue
        cells = [f"{res.row.label} (`{res.row.name}`)", _paper_cell(pv)]
        if est is None:
            cells += ["–", "–"] + (["–"] if std_col else []) + ["–", "0", "–"]
        else:
            cells += [est["mean"].fmt(), est["iqm"].fmt()]
            if std_col:
                cells.append(f"{est['mean'].value:.2f} ± {res.std[metric]:.2f}")
            diff = "–" if pv is None else f"{est['mean'].value - pv.value:+.2f}"
            frames = [r.frames for r in res.runs]
            cells += [diff, str(res.seeds[metric]), _fmt_frames(min(frames) if frames else None)]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _other_table_runs(out: Path, table: str, row: str) -> list[RunResult]:
    return load_runs(Path(out).parent / table / row)


def _efficiency_problems(lib: Library | None, conf_dir: Path, names: Sequence[str]) -> dict[str, list[str]]:
    try:
        rows = load_table("efficiency", conf_dir, rows=list(names))
    except ValueError:
        return {n: ["row config missing"] for n in names}
    by = {r.name: r for r in rows}
    return {r.name: (row_problems(r, lib, by) if lib is not None else []) for r in rows}


def _o1_section(results: Sequence[RowResult], table: str, out: Path, figdir: Path, lib: Library | None,
                conf_dir: Path, reps: int) -> list[str]:
    """O1 for a Meta-World table (this table's on-policy rows + the efficiency table's off-policy rows) or for the
    efficiency table itself (one figure per setting)."""
    lines = ["### O1: on-policy vs off-policy (wall-clock)", ""]
    if table == "efficiency":
        settings = sorted({str(r.row.meta.get("setting")) for r in results})
        sources = {s: {res.row.label: (res.runs, res.problems) for res in results
                       if res.row.meta.get("setting") == s} for s in settings}
    else:
        by = {res.row.name: res for res in results}
        names = [f"{table}_sac", f"{table}_pqn"]
        eff = _efficiency_problems(lib, conf_dir, names)
        group: dict[str, tuple[list[RunResult], list[str]]] = {}
        for label, name in (("MT-PPO", "vanilla"), ("MT-GRPO", "grpo_vanilla")):
            if name in by:
                group[label] = (by[name].runs, by[name].problems)
        for label, name in (("MT-SAC", f"{table}_sac"), ("MT-PQN", f"{table}_pqn")):
            if name in eff:
                group[label] = (_other_table_runs(out, "efficiency", name), eff[name])
        sources = {table: group}
    for setting, group in sources.items():
        groups = {label: runs for label, (runs, _) in group.items() if runs}
        path = figdir / f"o1_wallclock_{setting}.png"
        summary = plot_o1(groups, path, title=setting, reps=min(reps, 2000)) if groups else {}
        if summary:
            lines += [f"![O1 {setting}]({path.parent.name}/{path.name})", "",
                      "| algorithm | frames/run | training minutes | frames/s | final success (%) |",
                      "|---|---|---|---|---|"]
            for label, s in summary.items():
                lines.append(f"| {label} | {_fmt_frames(s['frames'])} | {s['minutes']:.1f} | "
                             f"{s['frames_per_s']:,.0f} | {s['success']:.2f} |")
            lines.append("")
        for label, (runs, problems) in group.items():
            if problems:
                lines.append(f"- {label} ({setting}): not available: {'; '.join(problems)}")
            elif not runs:
                lines.append(f"- {label} ({setting}): no runs yet")
        lines.append("")
    lines += ["Paper: " + " ".join(PAPER_NOTES["efficiency"]), ""]
    return lines


def _o3_section(results: Sequence[RowResult], figdir: Path, title: str) -> list[str]:
    lines = ["### O3: actor vs critic gradient conflict", ""]
    groups = {res.row.label: res.runs for res in results if res.runs}
    summaries = plot_o3(groups, figdir / "o3_cosine.png", title=title)
    if not summaries:
        return lines + ["No run of this table logged the gradient-cosine diagnostics (`train/grad_cos_*`; rows with "
                        "`grad.diagnostics_every > 0`, e.g. PCGrad / CAGrad / FAMO or table `cosine`).", ""]
    lines += ["![O3](" + figdir.name + "/o3_cosine.png)", "",
              "Time-averaged pairwise cosine similarity of per-task gradients (mean over seeds):", "",
              "| row | actor mean | actor min | critic mean | critic min | critic min < actor min |",
              "|---|---|---|---|---|---|"]
    for label, s in summaries.items():
        lines.append(f"| {label} (n={int(s['seeds'])}) | {s['actor_mean']:.3f} | {s['actor_min']:.3f} | "
                     f"{s['critic_mean']:.3f} | {s['critic_min']:.3f} | "
                     f"{'yes' if s['critic_min'] < s['actor_min'] else 'no'} |")
    lines += ["", "Paper: " + " ".join(PAPER_NOTES["cosine"]), ""]
    return lines


def _o4_section(results: Sequence[RowResult], figdir: Path, reps: int) -> list[str]:
    lines = ["### O4: curriculum vs no curriculum (Parkour-hard vs Parkour-hard-CL)", ""]
    by = {res.row.name: res for res in results}
    pairs, missing = {}, []
    for res in results:
        if res.row.meta.get("setting") != "hard":
            continue
        variant = res.row.meta.get("variant")
        cl = by.get(f"hard_cl_{variant}")
        if cl is None:
            continue
        if res.runs and cl.runs:
            pairs[res.row.label] = (res.runs, cl.runs)
        else:
            why = "; ".join(res.problems + cl.problems) or "no runs yet"
            missing.append(f"- {res.row.label}: {'not available: ' if res.problems or cl.problems else ''}{why}")
    est = plot_o4(pairs, figdir / "o4_curriculum.png", title="final progress", reps=reps) if pairs else {}
    if est:
        lines += ["![O4](" + figdir.name + "/o4_curriculum.png)", "",
                  "| variant | hard (%) | hard-CL (%) | CL − hard | paper CL − hard |", "|---|---|---|---|---|"]
        for label, e in est.items():
            variant = next(res.row.meta.get("variant") for res in results if res.row.label == label)
            ph, pc = paper_value("parkour", f"hard_{variant}", "progress"), paper_value(
                "parkour", f"hard_cl_{variant}", "progress")
            paper_diff = f"{pc.value - ph.value:+.2f}" if ph and pc else "–"
            lines.append(f"| {label} | {e['hard'].fmt()} | {e['hard_cl'].fmt()} | "
                         f"{e['hard_cl'].value - e['hard'].value:+.2f} | {paper_diff} |")
        lines.append("")
    lines += missing + ["", "Paper: " + PAPER_NOTES["parkour"][0], ""]
    return lines


OBSERVATIONS = {"mt10_rand": ("O1", "O3"), "mt50_rand": ("O1", "O3"), "efficiency": ("O1",), "cosine": ("O3",),
                "parkour": ("O4",)}


def build_report(
    table: str,
    *,
    out: Path | None = None,
    docs_dir: Path = DOCS_DIR,
    conf_dir: Path = CONF_DIR,
    lib: Library | None = None,
    reps: int = DEFAULT_REPS,
    command: str | None = None,
    notes: Sequence[str] = (),
) -> Path:
    """Write ``<docs_dir>/<table>.md`` and its PNGs; return the markdown path."""
    out = Path(out) if out is not None else REPO_ROOT / "runs" / "paper" / table
    rows = load_table(table, conf_dir)
    results = row_results(rows, out, lib, reps=reps)
    info = PAPER_TABLES.get(table, {"title": table, "source": "", "metric": "success", "frames": None, "seeds": None,
                                    "interval": ""})
    figdir = Path(docs_dir) / table
    md: list[str] = [f"# Paper reproduction: {info['title']} (`{table}`)", ""]
    all_frames = [r.frames for res in results for r in res.runs]
    paper_frames = info.get("frames")
    budget = "no runs yet"
    if all_frames:
        lo, hi = min(all_frames), max(all_frames)
        budget = f"{_fmt_frames(lo)}" + ("" if lo == hi else f" to {_fmt_frames(hi)}") + " frames per run"
        if paper_frames:
            budget += f" ({100.0 * hi / paper_frames:.2g}% of the paper's {_fmt_frames(paper_frames)})"
    md += [
        f"- Paper: {info['source']}; {_fmt_frames(paper_frames)} frames per run, {info.get('seeds')} seeds, "
        f"{info.get('interval')}.",
        f"- Ours: {budget}; runs under `{_rel(out)}`; final score of a seed = the last logged `success/mean` "
        f"(success window of the last iterations, mean over tasks){'; Parkour: progress' if info['metric'] == 'progress' else ''}.",
        f"- Aggregates over seeds: mean and IQM with 95% stratified bootstrap CIs (rliable, {reps:,} resamples, "
        "percentile method); with 3 or fewer seeds the IQM equals the mean (25% trimming drops no run).",
        f"- Built {time.strftime('%Y-%m-%d %H:%M')} by `{command or f'python -m mtbench.paper report {table}'}`.",
        *[f"- {note}" for note in notes],
        "",
    ]
    main = "progress" if info["metric"] == "progress" else "success"
    std_col = table == "parkour"
    md += [f"## {'Progress' if main == 'progress' else 'Success rate'} (%)", ""]
    md += _metric_table(results, table, main, "P (%)" if main == "progress" else "SR (%)", std_col) + [""]
    if any("return" in res.scores or paper_value(table, res.row.name, "return") for res in results):
        md += ["## Return", ""] + _metric_table(results, table, "return", "R", False) + [""]

    md += ["## Rows", "", "| row | label | config | paper frames | status |", "|---|---|---|---|---|"]
    for res in results:
        md.append(f"| `{res.row.name}` | {res.row.label} | {res.row.describe()} | {_fmt_frames(res.row.frames)} | "
                  f"{_status(res, out)} |")
    md.append("")

    curves = {res.row.label: res.runs for res in results if res.runs}
    if curves:
        md += ["## Learning curves", ""]
        ylabel = "progress (%)" if main == "progress" else "success rate (%)"
        overview = plot_curves(curves, figdir / "curves.png", title=f"{table}: {ylabel}", ylabel=ylabel,
                               reps=min(reps, 2000))
        if overview is not None:
            md += [f"![curves]({table}/curves.png)", ""]
        per_row = []
        for res in results:
            if res.runs:
                p = plot_curves({res.row.label: res.runs}, figdir / f"curve_{res.row.name}.png",
                                title=f"{table}/{res.row.name}", ylabel=ylabel, reps=min(reps, 2000))
                if p is not None:
                    per_row.append(f"[{res.row.name}]({table}/{p.name})")
        if per_row:
            md += ["Per row (mean over seeds, pointwise 95% bootstrap band): " + ", ".join(per_row), ""]

    obs = OBSERVATIONS.get(table, ())
    if obs:
        md += ["## Observations at reduced scale", ""]
        if "O1" in obs:
            md += _o1_section(results, table, out, figdir, lib, conf_dir, reps)
        if "O3" in obs:
            md += _o3_section(results, figdir, f"{table}: task-gradient cosine similarity")
        if "O4" in obs:
            md += _o4_section(results, figdir, reps)
    notes = [n for n in PAPER_NOTES.get(table, []) if table != "efficiency"]
    if notes:
        md += ["## Paper notes", ""] + [f"- {n}" for n in notes] + [""]
    path = Path(docs_dir) / f"{table}.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(md))
    return path


def _rel(path: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(REPO_ROOT))
    except ValueError:
        return str(path)
