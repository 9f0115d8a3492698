"""`export_runs`: run folders → one Parquet file of decisions and its dataset card.

Every RUN, the `--where` selectors and the output folder are checked before anything is
written; an export that fails while writing removes what it wrote of itself."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cocobench_agents.export.card import CardFacts, dataset_card
from cocobench_agents.export.decisions import EpisodeStats, Redactor, episode_rows
from cocobench_agents.export.errors import ExportError, ExportWriteError
from cocobench_agents.export.runs import Run, open_runs
from cocobench_agents.export.selection import Selection
from cocobench_agents.export.writer import DATA_FILE, check_out, require_pyarrow, write_rows
from cocobench_agents.partial_output import removed_on_failure
from cocobench_agents.runfolder import RunFolderError
from cocobench_agents.runfolder.infra import is_infra_failure, is_planner_failure

CARD_FILE = "README.md"


@dataclass
class ExportSummary:
    """What an export wrote, and what it left out (one line each, for the user)."""

    data_file: Path
    card_file: Path
    rows: int
    episodes: int
    images: int
    warnings: list[str] = field(default_factory=list)


def export_runs(runs: Sequence[str | Path], out: str | Path, *, where: Sequence[str] = (),
                include_infra: bool = False) -> ExportSummary:
    """Write the model decisions of the episodes of `runs` that pass every `where` selector
    (`selection.SELECTORS`) as `out/data/…parquet`, with its card `out/README.md`.
    Infrastructure failures (`runfolder.infra`) are left out unless `include_infra`, planner
    errors (the strategy's own code failed) always.
    `ExportError` for a mistake of the caller's, `ExportWriteError` when `out` cannot be
    written."""
    out = Path(out)
    selection = Selection.parse(where)
    opened = open_runs(runs)
    check_out(out)
    chosen, left_out = _choose(opened, selection, include_infra)
    require_pyarrow()
    warnings = [w for run in opened for w in run.warnings]
    redact = Redactor()
    stats = EpisodeStats()
    with removed_on_failure(out):
        data_file = _make_folders(out) / Path(DATA_FILE).name
        rows = write_rows(_rows(chosen, redact, stats), data_file)
        if rows == 0:
            raise ExportError("the selected episodes hold no model decision (an oracle "
                              "planner calls no model): nothing to export")
        card = dataset_card(CardFacts(opened, selection.describe(), chosen, stats,
                                      left_out), redact)
        card_file = _write_text(out / CARD_FILE, card)
    warnings += [f"{path}: missing; its episode is not exported"
                 for path in stats.missing_trajectories]
    return ExportSummary(data_file, card_file, rows, stats.episodes, stats.with_image,
                         warnings + [f"left out: {note}" for note in left_out])


def _choose(runs: Sequence[Run], selection: Selection, include_infra: bool
            ) -> tuple[list[tuple[Run, Mapping[str, Any]]], list[str]]:
    """The (run, result line) of every episode to export, and what was left out, counted.
    An episode the strategy's own code ended is never exported: its decisions are not the
    model's to learn from (and running it again fails the same way)."""
    chosen, infra, planner = [], 0, 0
    for run in runs:
        for line in run.episodes:
            if not selection.keeps(line):
                continue
            if is_planner_failure(line):
                planner += 1
            elif is_infra_failure(line) and not include_infra:
                infra += 1
            else:
                chosen.append((run, line))
    if not chosen:
        raise ExportError(_nothing_left(runs, selection, infra, planner))
    left_out = [f"{infra} infrastructure-failure episode(s) (--include-infra keeps them)"
                ] if infra else []
    if planner:
        left_out.append(f"{planner} planner-error episode(s) (the strategy's own code failed; "
                        "fix it and run them again)")
    return chosen, left_out


def _nothing_left(runs: Sequence[Run], selection: Selection, infra: int, planner: int) -> str:
    """Why no selected episode is exported."""
    if not infra and not planner:
        return selection.explain_empty(line for run in runs for line in run.episodes)
    if not infra:
        return (f"every selected episode ({planner}) is a planner error (the strategy's own "
                "code failed): nothing to export")
    if not planner:
        return (f"every selected episode ({infra}) is an infrastructure failure; pass "
                "--include-infra to export them anyway")
    return (f"every selected episode is an infrastructure failure ({infra}) or a planner "
            f"error ({planner}); pass --include-infra to export the infrastructure failures")


def _rows(chosen: Sequence[tuple[Run, Mapping[str, Any]]], redact: Redactor,
          stats: EpisodeStats) -> Iterator[dict[str, Any]]:
    for run, line in chosen:
        try:
            yield from episode_rows(run.folder, run.name, line, redact, stats)
        except RunFolderError as exc:  # a damaged trajectory or prompt file
            raise ExportError(str(exc)) from None


def _make_folders(out: Path) -> Path:
    data = out / Path(DATA_FILE).parent
    try:
        data.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportWriteError(f"cannot create {data}: {exc.strerror or exc}") from None
    return data


def _write_text(path: Path, text: str) -> Path:
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise ExportWriteError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path
