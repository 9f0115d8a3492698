"""`build_leaderboard`: verify each source (a bundle or a run folder), export its episodes'
pages, and write the site of its rows."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cocobench_agents.leaderboard.rows import Row, rank, rows_of
from cocobench_agents.leaderboard.site import write_site
from cocobench_agents.runfolder import RunFolder
from cocobench_agents.verify import RunVerification, VerifyError, reference_configs
from cocobench_agents.verify.run import opened, verify_opened
from cocobench_agents.viewer.export import export
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.source import Catalog

#: Where a source's `cocobench view --export` pages go, below the site.
PAGES = "runs"


@dataclass
class Leaderboard:
    """What was written: the site's index, its rows and each source's verification."""

    index: Path
    rows: list[Row]
    verifications: list[RunVerification]


def build_leaderboard(sources: Sequence[str | Path], out: str | Path, *,
                      reference: Mapping[str, Mapping[str, Any]] | None = None,
                      jobs: int | None = None) -> Leaderboard:
    """Verify every source, export its pages to ``out/runs/N/`` and write the leaderboard
    into `out` (new or empty: `VerifyError` otherwise)."""
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise VerifyError(f"{out}: the site folder exists and is not empty (choose a new one)")
    reference = reference_configs() if reference is None else reference
    rows: list[Row] = []
    verifications = []
    for number, source in enumerate(sources):
        with opened(source) as (folder, manifest):
            outcome = verify_opened(source, folder, manifest, reference=reference, jobs=jobs)
            pages = f"{PAGES}/{number}"
            export(Pages.create(Catalog([folder]), live=False), out / pages)
            rows += _source_rows(Path(source).name, f"{pages}/index.html", folder, outcome)
        verifications.append(outcome)
    rank(rows)
    rows.sort(key=lambda r: (r.condition, r.rank is None, r.rank or 0, r.model))
    return Leaderboard(write_site(rows, out), rows, verifications)


def _source_rows(name: str, pages: str, folder: Path, outcome: RunVerification) -> list[Row]:
    run = RunFolder(folder)
    record = run.run_record()
    lines = list(run.scan_results().latest.values())
    return rows_of(name, pages, lines, dict(outcome.verdicts), problems=outcome.problems,
                   labels=outcome.labels, suites=_suites(record))


def _suites(record: Mapping[str, Any]) -> dict[str, str]:
    """Each arm's prompt suite as ``spec@version`` ("" for a run of one suite)."""
    def named(suite: Any) -> str:
        if not isinstance(suite, Mapping):
            return str(suite or "")
        return f"{suite.get('spec')}@{suite.get('version')}"
    arms = record.get("prompt_suites")
    if isinstance(arms, list):
        return {str(s.get("arm") or ""): named(s) for s in arms if isinstance(s, Mapping)}
    return {"": named(record.get("prompt_suite"))}
