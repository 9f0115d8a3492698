"""Which episodes failed for infrastructure reasons: the one definition the live line, the run
summary, the report, the exit code of `cocobench run` and ``--retry-errors`` all use."""

from __future__ import annotations

import shlex
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any


def is_infra_failure(record: Mapping[str, Any]) -> bool:
    """Whether an episode's result does not measure the model: the episode could not run
    (``infra_error``: the harness, the simulator, a timeout), or one of its model calls got no
    answer after retries (``backend_errors``: HTTP errors, timeouts, an unknown model, input
    the model does not take). Such episodes count as failures in success rates, are counted
    as errors everywhere, and are what ``--resume --retry-errors`` runs again."""
    if record.get("infra_error"):
        return True
    try:
        return int(record.get("backend_errors") or 0) > 0
    except (TypeError, ValueError):
        return False


def count_infra_failures(records: Iterable[Mapping[str, Any]]) -> int:
    """How many of `records` are infrastructure failures."""
    return sum(is_infra_failure(r) for r in records)


def retry_command(out: str | Path) -> str:
    """The command that re-runs a run folder's infrastructure failures."""
    return f"cocobench run --out {shlex.quote(str(out))} --resume --retry-errors"
