"""Which episodes failed, and whose failure it was: the infrastructure's (the harness, the
simulator, a model call without an answer), which ``--retry-errors`` runs again, or the
planner's own code (`is_planner_failure`), which runs again only once the strategy is fixed.
The one definition the live line, the run summary, the report, the viewer, the exit code of
`cocobench run` and ``--retry-errors`` all use."""

from __future__ import annotations

import shlex
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any


def is_infra_failure(record: Mapping[str, Any]) -> bool:
    """Whether an episode's result does not measure the model: the episode could not run
    (``infra_error``: the harness, the simulator, a timeout), or one of its model calls got no
    answer after retries (`unanswered_calls`: HTTP errors, timeouts, an unknown model, input
    the model does not take). Such episodes count as failures in success rates, are counted
    as errors everywhere, and are what ``--resume --retry-errors`` runs again."""
    return bool(record.get("infra_error")) or unanswered_calls(record) > 0


def unanswered_calls(record: Mapping[str, Any]) -> int:
    """How many of an episode's model calls got no answer after retries: its
    ``usage.backend_errors`` (every call), or the reference's ``backend_errors`` where larger
    (that one counts only the decisions the trajectory's steps record, so it misses a call
    whose round ended the episode: a teammate's DONE beside it)."""
    usage = record.get("usage")
    counts = (record.get("backend_errors"),
              usage.get("backend_errors") if isinstance(usage, Mapping) else None)
    return max((count for count in counts if isinstance(count, int)), default=0)


def count_infra_failures(records: Iterable[Mapping[str, Any]]) -> int:
    """How many of `records` are infrastructure failures."""
    return sum(is_infra_failure(r) for r in records)


def is_planner_failure(record: Mapping[str, Any]) -> bool:
    """Whether the strategy's own code ended the episode (``planner_error``: a node raised,
    returned a malformed record, or the graph never ended): a failure of the planner under
    test, counted apart from the infrastructure's and never retried as one."""
    return bool(record.get("planner_error"))


def count_planner_failures(records: Iterable[Mapping[str, Any]]) -> int:
    """How many of `records` the planner's own code ended."""
    return sum(is_planner_failure(r) for r in records)


def retry_command(out: str | Path, record: Mapping[str, Any] | None = None) -> str:
    """The command that re-runs a run folder's infrastructure failures. For a run imported
    from an Inspect log (`record`, its run.json, names the log in ``imported_from``) that is
    Inspect's own retry of the log, then an import of the new log: `cocobench run` cannot
    resume a run it did not make. The command is built here from the log's path, never taken
    as text from the folder."""
    imported = record.get("imported_from") if isinstance(record, Mapping) else None
    log = imported.get("inspect_log") if isinstance(imported, Mapping) else None
    if isinstance(log, str) and log and "\0" not in log:
        return inspect_retry_command(log, out)
    return f"cocobench run --out {shlex.quote(str(out))} --resume --retry-errors"


def inspect_retry_command(log: str | Path, out: str | Path) -> str:
    """How to complete an interrupted Inspect eval or run its errored samples again, then
    read the result: Inspect's retry writes a new log, imported into a new folder."""
    return (f"inspect eval-retry {shlex.quote(str(log))}, then cocobench import-inspect "
            f"NEW_LOG --out {shlex.quote(str(out))}-retried")
