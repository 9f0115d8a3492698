"""Planner graphs: centralized (C0), decentralized (D0), decentralized with broadcast (D1),
leader–worker, and the oracle, behind the `PLANNERS` registry."""

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.registry import (
    PLANNERS,
    PlannerSpec,
    UnknownPlanner,
    compiled_graph,
    planner_spec,
)
from cocobench_agents.graphs.state import PlannerState

__all__ = ["PLANNERS", "PlannerContext", "PlannerSpec", "PlannerState", "UnknownPlanner",
           "compiled_graph", "planner_spec"]
