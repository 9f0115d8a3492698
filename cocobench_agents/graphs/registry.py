"""`PLANNERS`: every coordination strategy by name, and its compiled graph.

To add a strategy, write a module with a `build_…() -> StateGraph` and register a
`PlannerSpec` here (see docs/planners.md).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

from langgraph.graph import StateGraph

from cocobench_agents.graphs.centralized import build_centralized
from cocobench_agents.graphs.decentralized import build_decentralized
from cocobench_agents.graphs.leader_worker import build_leader_worker
from cocobench_agents.graphs.oracle import build_oracle


@dataclass(frozen=True)
class PlannerSpec:
    """A registered planner."""

    name: str
    code: str  # condition code in run folders and reports: C0, D0, D1, …
    build: Callable[[], StateGraph]
    decentralized: bool  # one model per agent (else one model for the team)
    uses_models: bool
    description: str


PLANNERS: dict[str, PlannerSpec] = {spec.name: spec for spec in (
    PlannerSpec("centralized", "C0", build_centralized, False, True,
                "one planner sees all views and moves one agent per step (paper C0)"),
    PlannerSpec("decentralized", "D0", functools.partial(build_decentralized, broadcast=False),
                True, True, "one model per agent, simultaneous decisions, no messages (D0)"),
    PlannerSpec("decentralized-broadcast", "D1",
                functools.partial(build_decentralized, broadcast=True), True, True,
                "D0 plus a broadcast message board (D1)"),
    PlannerSpec("leader-worker", "LW", build_leader_worker, True, True,
                "a leader model instructs each robot every round; robots decide in parallel"),
    PlannerSpec("oracle", "OR", build_oracle, False, False,
                "the cell's privileged reference plan"),
)}


class UnknownPlanner(ValueError):
    """A planner name that is not registered."""


def planner_spec(name: str) -> PlannerSpec:
    """The registered planner `name`."""
    try:
        return PLANNERS[name]
    except KeyError:
        raise UnknownPlanner(f"unknown planner {name!r} (available: "
                             f"{', '.join(PLANNERS)})") from None


@functools.cache
def compiled_graph(name: str):
    """The compiled graph of a planner (compiled once per process; no checkpointer)."""
    return planner_spec(name).build().compile()
