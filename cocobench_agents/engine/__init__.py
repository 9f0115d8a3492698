"""The engine: a typed `RunRequest` in, a run folder and its results out (`run`,
`run_async`), or a plan of what a request would cost without running it (`plan`).

Names load on first use (PEP 562): the command line imports the request types without the
planners, LangGraph or LiteLLM.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "RunRequest": ".request", "TaskSelection": ".request", "ExecutionSettings": ".request",
    "Limits": ".request",
    "run": ".run", "run_async": ".run", "plan": ".dry_run", "CostPlan": ".costs",
    "EvalResults": ".results", "RequestError": ".errors", "RunStopped": ".errors",
    "ConfigError": ".config", "layered_request": ".config",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
