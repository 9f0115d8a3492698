"""cocobench-agents: benchmark any LLM or VLM as a multi-agent household planner on CoCoBench.

The Python API (loaded on first use, so that importing the package stays cheap):
`run(RunRequest(...))` / `run_async` run a typed request (what ``cocobench run`` builds from
its flags, config file and environment); `plan(request)` says what it would cost without
calling a model; `evaluate` / `evaluate_async` build the request from keywords and run it;
`score` rescores a trajectory; `report` writes the paper's tables; `load_tasks` reads
suites, files and folders; `verify_source` replays a run folder or submission bundle in the
simulator; `build_leaderboard` writes the leaderboard site of what verifies.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr
from cocobench_agents.version import __version__

_EXPORTS = {
    "evaluate": "cocobench_agents.api", "evaluate_async": "cocobench_agents.api",
    "score": "cocobench_agents.api", "report": "cocobench_agents.api",
    "EvaluationError": "cocobench_agents.api",
    "RunRequest": "cocobench_agents.engine.request",
    "ModelSettings": "cocobench_agents.models.settings",
    "ExecutionSettings": "cocobench_agents.engine.request",
    "Limits": "cocobench_agents.engine.request",
    "TaskSelection": "cocobench_agents.engine.request",
    "run": "cocobench_agents.engine.run", "run_async": "cocobench_agents.engine.run",
    "plan": "cocobench_agents.engine.dry_run",
    "EvalResults": "cocobench_agents.engine.results",
    "RequestError": "cocobench_agents.engine.errors",
    "RunStopped": "cocobench_agents.engine.errors",
    "load_tasks": "benchmark_adapter.tasks",
    "verify_source": "cocobench_agents.verify", "build_leaderboard": "cocobench_agents.leaderboard",
}
__all__ = ["__version__", *sorted(_EXPORTS)]

__getattr__ = lazy_getattr(__name__, _EXPORTS)
