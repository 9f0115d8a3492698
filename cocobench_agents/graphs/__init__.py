"""Planner graphs: centralized (C0), decentralized (D0), decentralized with broadcast (D1),
leader–worker, and the oracle, behind the `PLANNERS` registry.

Names load on first use (PEP 562): reading the registry (`--help`, run plans, resume checks)
must not import LangGraph; building a graph does.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "PlannerContext": "context",
    "PLANNERS": "registry", "PlannerSpec": "registry", "UnknownPlanner": "registry",
    "compiled_graph": "registry", "planner_spec": "registry",
    "PlannerState": "state",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
