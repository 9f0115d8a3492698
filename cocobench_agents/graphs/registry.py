"""`PLANNERS`: the built-in coordination strategies by name; `planner_spec` resolves any
planner reference (a built-in, an installed plugin, `FILE.py:NAME`, `module:NAME`).

A new strategy lives in the researcher's own file or package, not here (`plugins.py`,
docs/planners.md).
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
    """A planner: how to build its graph and how a run gives it models. Your own strategy
    exports one (or just its build function) from a file or package (docs/planners.md)."""

    name: str  # set to the reference it is loaded by (a file's path, an entry point's name)
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

    arguments = ", ".join(f"{k}={v!r}" for k, v in kwargs.items())
    build.target = f"{target}({arguments})" if arguments else target  # for listings
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


class PlannerError(ValueError):
    """A planner that cannot be used: unknown, failing to load, or failing its check."""


class UnknownPlanner(PlannerError):
    """A planner name that is neither built in nor registered by an installed package."""


def planner_spec(name: str) -> PlannerSpec:
    """The planner `name`: a built-in (`centralized`, …), a planner an installed package
    registers (entry point group `cocobench.planners`), or code: `FILE.py:NAME` or
    `package.module:NAME`. User code is loaded once per process, so worker processes resolve
    the same string; the spec's `name` is the canonical reference (a file's absolute path)."""
    spec = PLANNERS.get(name)
    if spec is not None:
        return spec
    from cocobench_agents.graphs.plugins import load_planner

    return load_planner(name).spec


def find_planner(text: str) -> str | None:
    """The canonical name of the planner that `text` names or whose condition code it is
    (`C0`, `LW`, an installed plugin's code), or None; raises `PlannerError` for code that
    fails to load."""
    by_code = {spec.code: name for name, spec in PLANNERS.items()}
    if text in by_code or text in PLANNERS:
        return by_code.get(text, text)
    from cocobench_agents.graphs.plugins import find_user_planner

    return find_user_planner(text)


def compiled_graph(name: str):
    """The compiled graph of a planner (compiled once per process; no checkpointer)."""
    return _compiled(planner_spec(name).name)


@functools.cache
def _compiled(name: str):
    from langgraph.graph import StateGraph

    graph = planner_spec(name).build()
    if not isinstance(graph, StateGraph):
        raise PlannerError(f"planner {name}: its build function returned a "
                           f"{type(graph).__name__}, not a langgraph StateGraph")
    return graph.compile()
