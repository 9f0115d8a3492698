"""`build_leaderboard`: verify each source (a bundle or a run folder), export its episodes'
pages, and write the site of its rows."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cocobench_agents.leaderboard.rows import Row, rank, rows_of
from cocobench_agents.leaderboard.site import write_site
from cocobench_agents.partial_output import staged_beside
from cocobench_agents.runfolder import RunFolder
from cocobench_agents.verify import RunVerification, VerifyError, reference_configs
from cocobench_agents.verify.run import opened, verify_opened
from cocobench_agents.viewer.errors import ViewerError
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


class SiteWriteError(RuntimeError):
    """The site could not be written: a full or read-only disk (exit 1)."""


def build_leaderboard(sources: Sequence[str | Path], out: str | Path, *,
                      reference: Mapping[str, Mapping[str, Any]] | None = None,
                      jobs: int | None = None) -> Leaderboard:
    """Verify every source, export its pages to ``out/runs/N/`` and write the leaderboard
    into `out` (new or empty: `VerifyError` otherwise). The site is built in a hidden folder
    beside `out` and renamed to it once whole: a leaderboard killed or failing mid-way leaves
    no part of a site at `out`, and of two written there at once, the second to finish is
    refused (`VerifyError`) rather than mixed in. `SiteWriteError` for a disk that cannot
    take it."""
    out = Path(out)
    _check_new_or_empty(out)
    reference = reference_configs() if reference is None else reference
    with _staging_folder(out) as staging:
        rows, verifications = _write_sources(sources, staging, out, reference, jobs)
        try:
            write_site(rows, staging)
        except OSError as exc:
            raise SiteWriteError(f"cannot write {out}: {exc.strerror or exc}") from None
        _publish(staging, out)
    return Leaderboard(out / "index.html", rows, verifications)


def _check_new_or_empty(out: Path) -> None:
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise VerifyError(f"{out}: the site folder exists and is not empty (choose a new one)")


@contextlib.contextmanager
def _staging_folder(out: Path) -> Iterator[Path]:
    """A new hidden folder beside `out` (the same file system: renamed in one step), removed
    after unless published; those of leaderboards killed meanwhile are removed first."""
    with contextlib.ExitStack() as stack:
        try:
            staging = stack.enter_context(staged_beside(out, folder=True))
        except OSError as exc:
            raise SiteWriteError(f"cannot write {out}: {exc.strerror or exc}") from None
        yield staging


def _write_sources(sources: Sequence[str | Path], site: Path, out: Path,
                   reference: Mapping[str, Mapping[str, Any]], jobs: int | None
                   ) -> tuple[list[Row], list[RunVerification]]:
    """Verify each source and export its pages below `site` (to be `out`); the rows,
    ranked."""
    rows: list[Row] = []
    verifications = []
    for number, source in enumerate(sources):
        with opened(source) as (folder, manifest):
            outcome = verify_opened(source, folder, manifest, reference=reference, jobs=jobs)
            pages = f"{PAGES}/{number}"
            try:
                export(Pages.create(Catalog([folder]), live=False), site / pages)
            except ViewerError as exc:  # it cannot be written (the folder is new)
                raise SiteWriteError(str(exc).replace(str(site), str(out))) from None
            rows += _source_rows(Path(source).name, f"{pages}/index.html", folder, outcome)
        verifications.append(outcome)
    rank(rows)
    rows.sort(key=lambda r: (r.condition, r.rank is None, r.rank or 0, r.model))
    return rows, verifications


def _publish(staging: Path, out: Path) -> None:
    """Rename the whole site to `out`: rename(2) takes the place of a missing or empty
    folder only, so a site another leaderboard put there meanwhile is kept, not mixed."""
    try:
        staging.rename(out)
    except OSError as exc:
        if out.exists():
            raise VerifyError(f"{out}: another leaderboard wrote this site folder meanwhile; "
                              "it is kept, this one is not (choose a new one)") from None
        raise SiteWriteError(f"cannot write {out}: {exc.strerror or exc}") from None


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
