"""Planner graphs: centralized (C0), decentralized (D0), decentralized with broadcast (D1),
leader–worker, and the oracle, behind the `PLANNERS` registry; and the building blocks a
strategy of your own reuses (docs/planners.md, "Write it in your own file").

Names load on first use (PEP 562): reading the registry (`--help`, run plans, resume checks)
must not import LangGraph; building a graph does.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    # the registry, and planners from the researcher's code
    "PLANNERS": ".registry", "PlannerSpec": ".registry", "PlannerError": ".registry",
    "UnknownPlanner": ".registry", "lazy_builder": ".registry", "PAPER_PLANNERS": ".registry",
    "Seat": ".registry", "DEFAULT_PLANNER": ".registry", "ORACLE": ".registry",
    "NO_MODEL": ".registry",
    "compiled_graph": ".lookup", "planner_spec": ".lookup", "find_planner": ".lookup",
    "planner_rounds": ".lookup", "build_planners": ".lookup",
    # a round declared once as plain functions: its graph, and the loop that plays it
    "Rounds": ".rounds", "Node": ".rounds", "FanOut": ".rounds", "play_rounds": ".rounds",
    # what a strategy is made of
    "PlannerContext": ".context",
    "PlannerState": ".state", "TEAM": ".state", "team_history": ".state",
    "decide": ".decision", "ask": ".decision",
    "observe_next": ".nodes", "land_round": ".nodes", "continue_or_end": ".nodes",
    "fan_out": ".decentralized", "add_round": ".decentralized",
    "round_branches": ".decentralized", "branch_inputs": ".decentralized",
    "RetryPolicy": "cocobench_agents.models.retry",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
