"""Writing tables as Markdown and CSV, and the report's `index.md`.

Markdown shows an estimate as `41.7 [33.3, 50.0]` (rates in percent, scores 0-1, a difference
with its sign); CSV gives the same numbers, rounded to more decimals, in separate columns
`key`, `key_lo`, `key_hi`, `key_n`. NA is `NA` in Markdown and an empty field in CSV. Output is
byte-for-byte deterministic (LF line ends, no timestamps).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from cocobench_agents.reports.arms import recorded_settings
from cocobench_agents.reports.load import ReportData, RunInfo
from cocobench_agents.reports.result_tables import infra_warnings
from cocobench_agents.reports.stats import NA, Bootstrap, Estimate
from cocobench_agents.reports.table import KINDS, Column, Table

NA_TEXT = "NA"


def _number(value: float, decimals: int, signed: bool = False) -> str:
    text = f"{value:+.{decimals}f}" if signed else f"{value:.{decimals}f}"
    if float(text) == 0.0:  # no "-0.0" or "+0.0"
        text = f"{0.0:.{decimals}f}"
    return text


def _md_cell(column: Column, value: Any) -> str:
    if column.kind in KINDS:
        decimals, _, scale = KINDS[column.kind]
        if isinstance(value, Estimate):
            if value.na:
                return NA_TEXT
            signed = value.delta
            text = (f"{_number(value.value * scale, decimals, signed)} "
                    f"[{_number(value.lo * scale, decimals, signed)}, "
                    f"{_number(value.hi * scale, decimals, signed)}]")
            return f"{text} (n={value.n})" if column.show_n else text
        if value is None:
            return NA_TEXT
        return _number(float(value) * scale, decimals)
    if value is None:
        return ""
    return str(value).replace("|", "\\|")


def to_markdown(table: Table) -> str:
    """The table as a Markdown document: title, caption, table, notes."""
    shown = [i for i, c in enumerate(table.columns) if c.markdown]
    columns = [table.columns[i] for i in shown]
    header = [c.header for c in columns]
    body = [[_md_cell(c, row[i]) for c, i in zip(columns, shown)] for row in table.rows]
    widths = [max([len(h), 3, *(len(r[i]) for r in body)]) for i, h in enumerate(header)]
    right = [c.kind != "text" for c in columns]

    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(
            cell.rjust(w) if r else cell.ljust(w)
            for cell, w, r in zip(cells, widths, right)) + " |"

    rule = "| " + " | ".join(("-" * (w - 1) + ":") if r else "-" * w
                             for w, r in zip(widths, right)) + " |"
    parts = [f"# {table.title}", "", table.caption, ""]
    parts += warning_lines(table.warnings)
    if table.rows:
        parts += [line(header), rule, *(line(r) for r in body)]
    else:
        parts.append("_No episodes._")
    if table.notes:
        parts += ["", *(f"* {note}" for note in table.notes)]
    return "\n".join(parts) + "\n"


def warning_lines(warnings: Sequence[str]) -> list[str]:
    """Markdown lines that set each warning apart (a quoted, bold-labelled paragraph)."""
    return [line for warning in warnings for line in (f"> **Warning:** {warning}", "")]


def csv_header(table: Table) -> list[str]:
    out = []
    for c in table.columns:
        out += [c.key, f"{c.key}_lo", f"{c.key}_hi", f"{c.key}_n"] if c.has_ci else [c.key]
    return out


def _csv_number(value: float | None, column: Column) -> str:
    if value is None:
        return ""
    _, decimals, scale = KINDS[column.kind]
    return _number(value * scale, decimals)


def _csv_cells(column: Column, value: Any) -> list[str]:
    if column.has_ci:
        est = value if isinstance(value, Estimate) else NA
        return [_csv_number(est.value, column), _csv_number(est.lo, column),
                _csv_number(est.hi, column), str(est.n)]
    if column.kind in KINDS:
        return [_csv_number(None if value is None else float(value), column)]
    return ["" if value is None else str(value)]


def to_csv(table: Table) -> str:
    """The table as CSV (one header line; estimates in four columns)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(csv_header(table))
    for row in table.rows:
        writer.writerow([cell for c, v in zip(table.columns, row) for cell in _csv_cells(c, v)])
    return buffer.getvalue()


@dataclass(frozen=True)
class PlotEntry:
    """A plot written (or planned) for the index."""

    file: str
    title: str


def _run_row(run: RunInfo) -> list[str]:
    record = run.record
    planned = run.planned
    status = ("complete" if planned is not None and run.episodes >= planned
              else f"{run.episodes}/{planned}" if planned is not None else "unknown plan")
    notes = []
    if run.torn_tail:
        notes.append("incomplete last line skipped")
    if run.superseded:
        notes.append(f"{run.superseded} retried lines superseded")
    if run.invalid_lines:
        notes.append(f"{run.invalid_lines} invalid lines skipped")
    if run.missing_trajectories:
        notes.append(f"{run.missing_trajectories} trajectory files missing")
    models = ", ".join(run.plan.get("models") or [])
    if run.arms:  # one model in two arms is one model
        models += f"; arms: {', '.join(run.arms)}"
    return [run.name, str(record.get("created_at") or ""), models,
            ", ".join(run.conditions), ", ".join(map(str, run.plan.get("sources") or [])),
            str(run.episodes), status, str(run.infra_errors), "; ".join(notes)]


def counts_line(data: ReportData) -> str:
    """``N episodes of M model(s) [in A arm(s)] under C condition(s)``: arms are not models."""
    arms = data.arms()
    in_arms = f" in {len(arms)} arm(s)" if arms else ""
    return (f"{len(data.episodes)} episodes of {len(data.base_models())} model(s){in_arms} "
            f"under {len(data.conditions)} condition(s)")


def _md_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    esc = [[str(c).replace("|", "\\|") for c in r] for r in rows]
    return ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |",
            *("| " + " | ".join(r) + " |" for r in esc)]


def index_markdown(data: ReportData, tables: Sequence[Table], plots: Sequence[PlotEntry],
                   boot: Bootstrap, plot_note: str | None, *, clustered: bool = False) -> str:
    """The report's front page: runs, what was counted, links to tables and plots
    (`clustered`: some instance ran in several epochs, and intervals resample instances)."""
    lines = ["# CoCoBench report", "", f"{counts_line(data)}, from {len(data.runs)} run(s).", ""]
    lines += warning_lines([*data.warnings, *infra_warnings(data)])
    lines.append(f"* Models: {', '.join(data.base_models()) or '-'}")
    if data.arms():
        lines.append(f"* Arms: {', '.join(data.arms())}")
    lines.append(f"* Conditions: {', '.join(data.conditions) or '-'}")
    if data.superseded_across_runs:
        lines.append(f"* {data.superseded_across_runs} episodes found in several runs: the "
                     "later run's result is used.")
    over = ("instances (model, condition, task), all epochs of an instance together (a "
            "clustered bootstrap, docs/statistics.md)" if clustered else "episodes")
    lines += [f"* Intervals: {boot.confidence:.0%} percentile bootstrap over {over}, "
              f"{boot.resamples} resamples, seed {boot.seed}.", "", "## Runs", ""]
    lines += _md_table(["Run", "Created", "Models", "Conditions", "Source", "Episodes",
                        "Status", "Infra errors", "Notes"], [_run_row(r) for r in data.runs])
    lines += ["", "## Tables", ""]
    for t in tables:
        lines.append(f"* [{t.title}]({t.name}.md) ([CSV]({t.name}.csv))")
    lines += ["", "## Plots", ""]
    lines += [f"* [{p.title}]({p.file})" for p in plots]
    if plot_note:
        lines.append(plot_note)
    lines += ["", "## Versions", ""]
    packages = sorted({k for r in data.runs for k in (r.record.get("versions") or {})})
    lines += _md_table(["Run", "prompt suite", "backend", *packages], [
        [r.name, _prompt_suite(r.record),
         str(recorded_settings(r.record)[0].get("backend") or ""),
         *(str((r.record.get("versions") or {}).get(k, "")) for k in packages)]
        for r in data.runs])
    return "\n".join(lines) + "\n"


def _prompt_suite(record: dict[str, Any]) -> str:
    if isinstance(record.get("prompt_suites"), list):  # a run with prompt-suite arms
        return ", ".join(_prompt_suite({"prompt_suite": s}) for s in record["prompt_suites"])
    suite = record.get("prompt_suite") or {}
    if isinstance(suite, dict):
        return " ".join(str(v) for v in (suite.get("spec"), suite.get("version")) if v)
    return str(suite)
