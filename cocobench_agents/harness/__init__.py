"""Batch runs: suite × conditions × models × epochs into a resumable run folder (its format:
`cocobench_agents.runfolder`).

Names load on first use (PEP 562): a module that needs one name does not import the planners
and LangGraph.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "execute": ".batch", "execute_and_close": ".batch", "infra_error_record": ".batch",
    "run_one": ".batch",
    "Condition": ".plan", "PlanError": ".plan", "PlannedEpisode": ".plan",
    "RunOptions": ".plan", "parse_conditions": ".plan", "plan_episodes": ".plan",
    "pending_episodes": ".pending",
    "WorkerError": ".workers", "available_cores": ".workers", "execute_in_workers": ".workers",
    "RayOptions": ".ray_executor", "execute_on_ray": ".ray_executor",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
