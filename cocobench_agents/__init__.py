"""cocobench-agents: benchmark any LLM or VLM as a multi-agent household planner on CoCoBench.

The Python API (loaded on first use, so that importing the package stays cheap):
`evaluate` / `evaluate_async` run what ``cocobench run`` runs; `score` rescores a trajectory;
`report` writes the paper's tables; `load_tasks` reads suites, files and folders.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_EXPORTS = {
    "evaluate": "cocobench_agents.api", "evaluate_async": "cocobench_agents.api",
    "score": "cocobench_agents.api", "report": "cocobench_agents.api",
    "EvalResults": "cocobench_agents.api", "EvaluationError": "cocobench_agents.api",
    "load_tasks": "benchmark_adapter.tasks",
}
__all__ = ["__version__", *sorted(_EXPORTS)]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
