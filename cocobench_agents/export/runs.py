"""The run folders an export reads, checked before anything is written: each must exist, be
a run folder, and be finished (no live run holding its lock); what each holds that cannot be
exported (a torn last line, invalid lines, missing trajectories, infrastructure failures) is
said in warnings, never silently dropped."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cocobench_agents.export.errors import ExportError
from cocobench_agents.runfolder import RUN_FILE, RunFolder, RunFolderError, holder


@dataclass
class Run:
    """One finished run folder: its record, and the episodes it counts as done."""

    folder: RunFolder
    record: dict[str, Any]
    episodes: list[dict[str, Any]]  # the latest valid result line of each done episode
    warnings: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return str(self.record.get("name") or self.folder.path.name)


def open_runs(paths: Sequence[str | Path]) -> list[Run]:
    """Every RUN checked and read (`ExportError` naming the first that cannot be exported)."""
    seen: dict[Path, str] = {}
    runs = []
    for given in paths:
        path = Path(given)
        resolved = path.resolve()
        if resolved in seen:
            raise ExportError(f"{given}: given twice (as {seen[resolved]}): its decisions "
                              "would be exported twice")
        seen[resolved] = str(given)
        runs.append(open_run(path))
    return runs


def open_run(path: Path) -> Run:
    """One run folder, checked (`ExportError` saying why it cannot be exported)."""
    if not path.exists():
        raise ExportError(f"{path}: no such run folder")
    if not path.is_dir():
        raise ExportError(f"{path}: not a run folder (a file; give the folder `cocobench run "
                          "--out` wrote)")
    if not (path / RUN_FILE).exists():
        raise ExportError(f"{path}: not a run folder (no {RUN_FILE}; give the folder "
                          "`cocobench run --out` wrote)")
    locked = holder(path)
    if locked is not None:
        raise ExportError(f"{locked}; export it once the run has ended (an export of a run "
                          "in progress would miss the episodes still to come)")
    folder = RunFolder(path)
    try:
        record = folder.run_record()
        scan = folder.scan_results(check_trajectories=True)
    except (RunFolderError, OSError) as exc:
        raise ExportError(str(exc) if isinstance(exc, RunFolderError) else
                          f"{path}: unreadable ({exc.strerror or exc})") from None
    run = Run(folder, record, list(scan.done.values()), list(scan.problems))
    if scan.torn_tail:
        run.warnings.append(f"{folder.results_path}: its last line is incomplete (a run "
                            "stopped in mid-write): that episode is not exported; `cocobench "
                            f"run --out {path} --resume` completes it")
    return run
