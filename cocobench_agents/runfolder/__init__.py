"""The run folder: the format every reader of a run depends on (DESIGN §4).

`run.json` (its layouts: `upgrade`), `results.jsonl` (a valid line: `result_line`; which
lines are infrastructure or planner failures: `infra`; the closing summary: `summary`), one
trajectory and its prompts per episode (`folder`, keyed by `episode_key`), appended
whole-line files (`json_lines`) and `run.lock` (`lock`). The harness writes it; the engine,
the reports and the viewer read it, and import nothing of the harness.

Names load on first use (PEP 562): reading a run folder imports no planner, LangGraph or
model client.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "EpisodeKey": ".episode_key", "model_slug": ".episode_key", "result_key": ".episode_key",
    "RunFolderError": ".errors", "RunFolderWriteError": ".errors",
    "PROMPTS_FILE": ".folder", "RESULTS": ".folder", "RUN_FILE": ".folder",
    "ResultsScan": ".folder", "RunFolder": ".folder",
    "count_infra_failures": ".infra", "count_planner_failures": ".infra",
    "is_infra_failure": ".infra", "is_planner_failure": ".infra", "retry_command": ".infra",
    "unanswered_calls": ".infra",
    "LOCK_FILE": ".lock", "RunLock": ".lock", "RunLocked": ".lock", "holder": ".lock",
    "CS_NOTE": ".result_line", "ResultLine": ".result_line",
    "infra_error_line": ".result_line", "line_error": ".result_line",
    "planner_error_line": ".result_line",
    "HEADERS": ".summary", "LEGEND": ".summary", "latest": ".summary",
    "node_lines": ".summary", "summary_table": ".summary",
    "RECORD_VERSION": ".upgrade",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
