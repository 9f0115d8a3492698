"""Batch runs: suite × conditions × models × epochs into a resumable run folder, on one of
the executors (`executors`).

Names load on first use (PEP 562): reading a run folder (reports) must not import the
planners and LangGraph.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "Bounds": ".executor", "Executor": ".executor", "executor_named": ".executors",
    "ExecutionSettings": ".execution_settings",
    "InProcess": ".batch", "infra_error_record": ".batch", "run_batch": ".batch",
    "run_one": ".batch",
    "Condition": ".episodes", "EpisodeKey": ".store", "PlanError": ".episodes",
    "PlannedEpisode": ".episodes",
    "parse_conditions": ".episodes", "plan_episodes": ".episodes",
    "pending_episodes": ".pending",
    "RunFolder": ".store", "RunFolderError": ".store",
    "WorkerError": ".workers", "WorkerProcesses": ".workers", "available_cores": ".workers",
    "RayExecutor": ".ray_executor",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
