"""Batch runs: suite × conditions × models × epochs into a resumable run folder (its format:
`cocobench_agents.runfolder`), on one of the executors (`executors`).

Names load on first use (PEP 562): a module that needs one name does not import the planners
and LangGraph.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "Bounds": ".executor", "Executor": ".executor", "executor_named": ".executors",
    "ExecutionSettings": ".execution_settings",
    "InProcess": ".batch", "infra_error_record": ".batch", "run_batch": ".batch",
    "run_one": ".batch",
    "Condition": ".episodes", "PlanError": ".episodes", "PlannedEpisode": ".episodes",
    "parse_conditions": ".episodes", "plan_episodes": ".episodes",
    "pending_episodes": ".pending",
    "WorkerError": ".workers", "WorkerProcesses": ".workers", "available_cores": ".workers",
    "RayExecutor": ".ray_executor",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
