"""`EvalResults`: what a run returns, read from its run folder."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from cocobench_agents.runfolder.folder import RunFolder


class EvalResults(list):
    """The result lines of a run (one dict per episode, the fields of ``results.jsonl``).

    `folder` is the run folder; `errors` counts episodes that the model's infrastructure or
    the harness ended, `planner_errors` those the planner's own code ended (never retried);
    `stopped` says why the run did not finish every episode (a spend limit), or is None.
    """

    def __init__(self, records: list[dict[str, Any]], folder: Path, errors: int,
                 stopped: str | None, planner_errors: int = 0) -> None:
        super().__init__(records)
        self.folder, self.errors, self.stopped = folder, errors, stopped
        self.planner_errors = planner_errors

    @property
    def results_file(self) -> Path:
        """The run's ``results.jsonl``, every line of which these results were read from."""
        from cocobench_agents.runfolder.folder import RESULTS

        return self.folder / RESULTS


def collect_results(out: Path | RunFolder, stopped: str | None = None) -> EvalResults:
    """The latest result line of every episode recorded in run folder `out`: a path, or the
    run's own `RunFolder`, which kept what it appended and reads no line again."""
    from cocobench_agents.runfolder.folder import RunFolder
    from cocobench_agents.runfolder.infra import count_infra_failures, count_planner_failures
    from cocobench_agents.runfolder.summary import latest

    folder = out if isinstance(out, RunFolder) else RunFolder(out)
    records = latest(folder.results())
    return EvalResults(records, folder.path, count_infra_failures(records), stopped,
                       count_planner_failures(records))
