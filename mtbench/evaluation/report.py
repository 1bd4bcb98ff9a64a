"""The per-task evaluation table (markdown, also printed) and the JSON report."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Sequence

from ..trainer.metrics import percent
from .episodes import EvalResult


def _num(value: float, digits: int = 1) -> str:
    return "n/a" if value != value else f"{value:.{digits}f}"


def _markdown(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A markdown table with columns padded to their widest cell (the first left-aligned, the rest right)."""
    align = ["---"] + ["---:"] * (len(header) - 1)
    widths = [max(len(str(x)) for x in col) for col in zip(header, align, *rows)]

    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(str(c).ljust(w) for c, w in zip(cells, widths)) + " |"

    return "\n".join([line(header), line(align), *(line(r) for r in rows)])


def markdown_table(results: Sequence[EvalResult]) -> str:
    """One row per task and a mean row; per evaluation (sampled, deterministic) a success, return and length
    column, then the finished episodes (one column when both evaluations have the same counts). Task slots without
    an episode in any evaluation (an env without worlds of them, e.g. Parkour's 21 slots in a run on a few terrains:
    every world finishes an episode per pass) are left out, with a line that says how many."""
    if not results:
        raise ValueError("no evaluation results")
    names = results[0].task_names
    metric = results[0].metric
    header = ["task"]
    for r in results:
        header += [f"{metric} ({r.mode})", f"return ({r.mode})", f"length ({r.mode})"]
    same_counts = all(r.episodes == results[0].episodes for r in results)
    header += ["episodes"] if same_counts else [f"episodes ({r.mode})" for r in results]
    counted = results[:1] if same_counts else results
    shown = [i for i in range(len(names)) if any(r.episodes[i] > 0 for r in results)]
    rows = []
    for i in shown:
        row = [names[i]]
        for r in results:
            row += [percent(r.success[i]), _num(r.returns[i]), _num(r.lengths[i])]
        row += [str(r.episodes[i]) for r in counted]
        rows.append(row)
    mean = ["**mean**"]
    for r in results:
        mean += [f"**{percent(r.mean_success)}**", _num(r.mean_return), _num(r.mean_length)]
    mean += [str(sum(r.episodes)) for r in counted]
    rows.append(mean)
    table = _markdown(header, rows)
    hidden = len(names) - len(shown)
    if hidden:
        table += f"\n\n({hidden} task slot{'s' if hidden > 1 else ''} without worlds in this env not shown)"
    return table


def end_table(results: Sequence[EvalResult]) -> str:
    """How the counted episodes ended (each reason's share per task, the rows sum to 100%), one column group per
    evaluation; empty when the env reports no end reasons."""
    shares = [r.end_shares() for r in results]
    if not shares or not shares[0]:
        return ""
    reasons = list(shares[0])
    header = ["task"] + [f"{reason} ({r.mode})" if len(results) > 1 else reason
                         for r in results for reason in reasons]
    rows = [[name] + [percent(s[reason][i]) for s in shares for reason in reasons]
            for i, name in enumerate(results[0].task_names) if results[0].episodes[i] > 0]
    return _markdown(header, rows)


def report_tables(results: Sequence[EvalResult]) -> str:
    """:func:`markdown_table`, then, for an env that reports end reasons, :func:`end_table` under its heading: what
    ``examples/eval.py`` prints and ``eval.md`` holds."""
    ends = end_table(results)
    table = markdown_table(results)
    return f"{table}\n\nHow the counted episodes ended:\n\n{ends}" if ends else table


def _finite(value: Any) -> Any:
    """JSON has no NaN: non-finite floats become ``None``."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def write_reports(out: Path, results: Sequence[EvalResult], info: dict[str, Any]) -> tuple[Path, Path]:
    """``out/eval.md`` (what was evaluated + the table) and ``out/eval.json`` (``info`` + per-evaluation results)."""
    out.mkdir(parents=True, exist_ok=True)
    md = out / "eval.md"
    lines = ["# Evaluation", ""]
    for key in ("checkpoint", "env", "env_overrides", "arch", "loss", "iteration", "frames", "device", "num_envs",
                "seed", "episodes_requested"):
        if key in info and (key != "env_overrides" or info[key]):
            lines.append(f"- {key}: `{info[key]}`")
    lines += ["", report_tables(results), ""]
    if info.get("videos"):
        lines += ["Videos:", ""] + [f"- {task}: `{path}`" for task, path in info["videos"].items()] + [""]
    md.write_text("\n".join(lines))
    js = out / "eval.json"
    payload = {**info, "evaluations": {r.mode: r.as_dict() for r in results}}
    js.write_text(json.dumps(_finite(payload), indent=2, default=str) + "\n")
    return md, js


__all__ = ["end_table", "markdown_table", "report_tables", "write_reports"]
