"""The closing summary of a run: success and construct scores per model and condition (and
prompt-suite arm, in a run that compares several)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from typing import Any

from benchmark_adapter.vocabulary import DIMENSIONS
from cocobench_agents.runfolder.episode_key import result_key
from cocobench_agents.runfolder.infra import (
    count_infra_failures,
    count_planner_failures,
    is_planner_failure,
)
from cocobench_agents.runfolder.result_line import CS_NOTE

HEADERS = ("model", "condition", "episodes", "SR", "CS", *(f"CS_{d}" for d in DIMENSIONS), "legal",
           "errors")
#: The column added after `errors` when a planner's own code ended some episode.
PLANNER_ERRORS = "planner errors"
#: The legend under a summary table (the run's closing summary, the viewer's runs page).
LEGEND = ("SR: task success rate. CS: mean construct score of the scored episodes (n), "
          "CS_D1..D4 per dimension; unscored episodes are not_engaged (no evidence of the "
          "construct), low_signal (too little evidence) or na_no_actions (no step taken). "
          f"{CS_NOTE} legal: plans with no illegal step. errors: episodes the model's "
          "infrastructure or the harness ended. planner errors (shown when there are any): "
          "episodes the strategy's own code ended (a node raised, returned a malformed "
          "record, or never ended); both count as failures.")


def summary_table(records: Iterable[dict[str, Any]]) -> tuple[tuple[str, ...], list[list[Any]]]:
    """The headers and one row per (model, condition): episodes, success rate, mean
    construct score overall and per dimension (scored episodes only), legal-plan rate, and
    the infrastructure failures (`is_infra_failure`), and where a planner's code ended some
    episode (`is_planner_failure`), a `planner errors` column counting those. Records with
    prompt-suite arms get one row per (model, condition, arm) and an `arm` column, arms in
    the order they first appear (the order they were given)."""
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    for record in latest(records):
        key = result_key(record)
        groups.setdefault((key.model, key.condition, key.arm), []).append(record)
    arms = list(dict.fromkeys(arm for _, _, arm in groups))
    order = sorted(groups, key=lambda g: (g[0], g[1], arms.index(g[2])))
    planner = any(is_planner_failure(r) for rows in groups.values() for r in rows)
    headers = (*HEADERS, PLANNER_ERRORS) if planner else HEADERS
    rows = [[model, condition, arm, *_row(groups[model, condition, arm], planner)]
            for model, condition, arm in order]
    if arms in ([], [""]):
        return headers, [[model, condition, *rest] for model, condition, _, *rest in rows]
    return (*headers[:2], "arm", *headers[2:]), rows


def summary_rows(records: Iterable[dict[str, Any]]) -> list[list[Any]]:
    """The rows of `summary_table`."""
    return summary_table(records)[1]


def node_lines(records: Iterable[dict[str, Any]]) -> list[str]:
    """Where a Ray run's episodes ran: a line per Ray node (the ``node`` of result lines),
    busiest first, with the episodes it ran and how many of those it ran after another
    worker had lost them (``requeued``); none when no line names a node (a local run)."""
    ran: Counter[str] = Counter()
    requeued: Counter[str] = Counter()
    for record in latest(records):
        node = record.get("node")
        if isinstance(node, str) and node:
            ran[node] += 1
            requeued[node] += bool(record.get("requeued"))
    lines = []
    for node, count in sorted(ran.items(), key=lambda item: (-item[1], item[0])):
        again = f", {requeued[node]} of them re-queued from a lost worker" if requeued[node] else ""
        lines.append(f"node {node}: {count} episode{'s' if count != 1 else ''}{again}")
    return lines


def latest(records: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The last line of each episode (a retry supersedes the first attempt)."""
    return list({result_key(r): r for r in records}.values())


def _row(rows: list[dict[str, Any]], planner: bool) -> list[Any]:
    ran = [r for r in rows if not r.get("infra_error") and not is_planner_failure(r)]
    legal = [r["legal_plan"] for r in ran if r.get("legal_plan") is not None]
    return [len(rows), _rate([r["task_success"] for r in rows]),
            _mean_construct(ran), *(_mean_construct([r for r in ran if r.get("dim") == d])
                                   for d in DIMENSIONS),
            _rate(legal), count_infra_failures(rows),
            *([count_planner_failures(rows)] if planner else [])]


def _mean_construct(rows: list[dict[str, Any]]) -> str:
    scores = [r["construct_score"] for r in rows if r.get("construct_score") is not None]
    return f"{sum(scores) / len(scores):.2f} (n={len(scores)})" if scores else "-"


def _rate(values: list[Any]) -> str:
    return f"{100 * sum(values) / len(values):.1f}%" if values else "-"
