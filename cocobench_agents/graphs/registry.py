"""`PLANNERS`: every coordination strategy by name, and its compiled graph.

To add a strategy, write a module with a `build_…() -> StateGraph` and register a
`PlannerSpec` here (see docs/planners.md).
"""

from __future__ import annotations

import functools
import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from cocobench_agents.models.retry import RetryPolicy

if TYPE_CHECKING:
    from langgraph.graph import StateGraph


@dataclass(frozen=True)
class PlannerSpec:
    """A registered planner."""

    name: str
    code: str  # condition code in run folders and reports: C0, D0, D1, …
    build: Callable[[], StateGraph]
    decentralized: bool  # one model per agent (else one model for the team)
    uses_models: bool
    description: str
    # How this strategy retries transient model failures; None: the run-level options.
    retry_policy: RetryPolicy | None = None


def lazy_builder(target: str, **kwargs: Any) -> Callable[[], StateGraph]:
    """A graph builder named ``module:function``, imported when a graph is first built (so
    the registry can be read without importing LangGraph)."""

    def build() -> StateGraph:
        module, _, name = target.partition(":")
        return getattr(importlib.import_module(module), name)(**kwargs)

    return build


_GRAPHS = "cocobench_agents.graphs"
PLANNERS: dict[str, PlannerSpec] = {spec.name: spec for spec in (
    PlannerSpec("centralized", "C0", lazy_builder(f"{_GRAPHS}.centralized:build_centralized"),
                False, True,
                "one planner sees all views and moves one agent per step (paper C0)"),
    PlannerSpec("decentralized", "D0",
                lazy_builder(f"{_GRAPHS}.decentralized:build_decentralized", broadcast=False),
                True, True, "one model per agent, simultaneous decisions, no messages (D0)"),
    PlannerSpec("decentralized-broadcast", "D1",
                lazy_builder(f"{_GRAPHS}.decentralized:build_decentralized", broadcast=True),
                True, True, "D0 plus a broadcast message board (D1)"),
    PlannerSpec("leader-worker", "LW", lazy_builder(f"{_GRAPHS}.leader_worker:build_leader_worker"),
                True, True,
                "a leader model instructs each robot every round; robots decide in parallel"),
    PlannerSpec("oracle", "OR", lazy_builder(f"{_GRAPHS}.oracle:build_oracle"), False, False,
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
