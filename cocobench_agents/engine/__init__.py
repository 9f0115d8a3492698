"""The engine: a typed `RunRequest` in, a run folder and its results out (`run`,
`run_async`), or a plan of what a request would cost without running it (`plan`).

Names load on first use (PEP 562): the command line imports the request types without the
planners, LangGraph or LiteLLM.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "RunRequest": "request", "TaskSelection": "request", "ExecutionSettings": "request",
    "Limits": "request",
    "run": "run", "run_async": "run", "plan": "dry_run", "CostPlan": "estimate",
    "EvalResults": "results", "RequestError": "errors", "RunStopped": "errors",
    "ConfigError": "config", "layered_request": "config",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
