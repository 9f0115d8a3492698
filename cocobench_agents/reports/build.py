"""`build_report`: run folders in, Markdown/CSV tables, PNG plots and `index.md` out."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from benchmark_adapter.vocabulary import IMAGE
from cocobench_agents.conditions import condition_name
from cocobench_agents.reports import compare, diagnostics, paired, reliability, result_tables
from cocobench_agents.reports.load import ReportData, ReportError, load_runs
from cocobench_agents.reports.render import PlotEntry, index_markdown, to_csv, to_markdown
from cocobench_agents.reports.stats import Bootstrap
from cocobench_agents.reports.table import Table

#: Every table of the report, in the order of the index.
TABLES: tuple[Callable[[result_tables.Ctx], Table], ...] = (
    result_tables.main_results,
    result_tables.architecture,
    result_tables.observation,
    result_tables.team_size,
    diagnostics.failure_diagnostics,
    diagnostics.terminal_states,
    diagnostics.legality,
    diagnostics.cost,
    diagnostics.construct_correlation,
)
PRIMARY_CONDITION = condition_name(result_tables.BASELINE_ARCH, IMAGE)  # the paper's main protocol
#: What every table of a report with repeated epochs says about its intervals.
CLUSTERED_NOTE = ("Intervals resample instances (model, condition, task) with all their epochs "
                  "together (a clustered bootstrap: epochs of one instance are not independent "
                  "trials); n still counts episodes. See docs/statistics.md.")


class ReportWriteError(RuntimeError):
    """The report folder could not be written (no permission, a read-only or full disk):
    one line naming the path, exit code 1 (the runs read are not at fault)."""


@dataclass
class ReportSummary:
    """What `build_report` wrote."""

    out: Path
    files: list[Path]
    tables: list[Table]
    plots: list[PlotEntry] = field(default_factory=list)
    plot_note: str | None = None  # why plots are missing, when they are
    episodes: int = 0
    models: list[str] = field(default_factory=list)  # each once, however many arms it ran in
    arms: list[str] = field(default_factory=list)
    conditions: list[str] = field(default_factory=list)
    plot_condition: str | None = None
    warnings: list[str] = field(default_factory=list)  # about the runs read (invalid lines)


def compute_tables(data: ReportData, boot: Bootstrap | None = None,
                   baseline: str | None = None) -> list[Table]:
    """Every report table for already loaded runs (the arms table only when they have
    arms: see `paired`; model comparisons with two models or more, against `baseline` if
    given; reliability only when some instance ran in several epochs)."""
    ctx = result_tables.Ctx(data, boot or Bootstrap())
    made = [make(ctx) for make in TABLES]
    extra = []
    if paired.arm_groups(data):
        extra.append(paired.arms_table(ctx))  # an ablation's result: next to the main one
    compared = compare.compare(ctx, baseline)
    if compared.rows:
        extra.append(compared)
    if ctx.clustered:
        extra.append(reliability.reliability(ctx))
    made[1:1] = extra
    if ctx.clustered:
        for table in made:
            table.notes.append(CLUSTERED_NOTE)
    return made


def plot_condition(data: ReportData, wanted: str | None = None) -> str | None:
    """The condition per-condition figures show: `wanted`, else C0_image, else the first."""
    if wanted is not None:
        if wanted not in data.conditions:
            raise ReportError(f"--plot-condition {wanted}: no episodes under it (conditions: "
                                f"{', '.join(data.conditions) or 'none'})")
        return wanted
    if PRIMARY_CONDITION in data.conditions:
        return PRIMARY_CONDITION
    return data.conditions[0] if data.conditions else None


def build_report(runs: Sequence[str | Path], out: str | Path, *,
                 boot: Bootstrap | None = None, plots: bool = True,
                 condition: str | None = None, arms: bool = False,
                 baseline: str | None = None) -> ReportSummary:
    """Read the run folders (merged, later runs winning) and write the report into `out`.

    `condition` is the one per-condition figures show (default C0_image, else the first).
    Plots are skipped, with a note in the summary and index, when matplotlib is missing.
    Runs whose settings differ cannot share a row unless `arms` (see `load_runs`).
    `baseline`: the model (report row) every other model is compared with (default: every
    pair of models).
    """
    boot = boot or Bootstrap()
    data = load_runs(list(runs), arms=arms)
    shown = plot_condition(data, condition)
    out = Path(out)
    made = compute_tables(data, boot, baseline)
    with _writing(out):
        return _write_report(data, made, out, boot, plots=plots, shown=shown)


@contextlib.contextmanager
def _writing(out: Path) -> Iterator[None]:
    """`ReportWriteError` naming the file for a report that cannot be written."""
    try:
        yield
    except OSError as exc:
        where = exc.filename or out
        raise ReportWriteError(f"cannot write {where}: {exc.strerror or exc}") from None


def _write_report(data: ReportData, made: list[Table], out: Path, boot: Bootstrap, *,
                  plots: bool, shown: str | None) -> ReportSummary:
    out.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []
    for table in made:
        files.append(_write(out / f"{table.name}.md", to_markdown(table)))
        files.append(_write(out / f"{table.name}.csv", to_csv(table)))
    written: list[PlotEntry] = []
    note = None
    if not plots:
        note = "Plots were not requested (--no-plots)."
    elif shown is None:
        note = "No episodes, so no plots."
    else:
        from cocobench_agents.reports.plots import PlotsUnavailable, write_plots

        try:
            written = write_plots(made, out, shown)
        except PlotsUnavailable as exc:
            note = str(exc)
        else:
            if written:
                note = f"Per-condition figures show {shown}."
    files += [out / p.file for p in written]
    files.insert(0, _write(out / "index.md", index_markdown(
        data, made, written, boot, note, clustered=any(CLUSTERED_NOTE in t.notes for t in made))))
    return ReportSummary(out=out, files=files, tables=made, plots=written, plot_note=note,
                         episodes=len(data.episodes), models=data.base_models(), arms=data.arms(),
                         conditions=list(data.conditions), plot_condition=shown,
                         warnings=list(data.warnings))


def _write(path: Path, text: str) -> Path:
    try:
        with open(path, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
    except OSError as exc:  # a write fails without naming its file (EFBIG, ENOSPC)
        raise ReportWriteError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path
