"""Any planner by reference: a built-in (`registry.PLANNERS`), a planner an installed package
registers, or code (`FILE.py:NAME`, `package.module:NAME`, `plugins.py`); and its compiled
graph.

It sits above both `registry` and `plugins`, so that neither imports the other's lookups.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from cocobench_agents.graphs.plugins import find_user_planner, load_planner
from cocobench_agents.graphs.registry import PLANNERS, PlannerError, PlannerSpec

if TYPE_CHECKING:
    from cocobench_agents.graphs.rounds import Rounds

# Compiled once per process, by canonical name. A user planner loaded afresh
# (`plugins.forget_user_planners`) is a new spec, so it compiles again.
_COMPILED: dict[str, tuple[PlannerSpec, Any]] = {}
_ROUNDS: dict[str, tuple[PlannerSpec, Rounds]] = {}


def planner_spec(name: str) -> PlannerSpec:
    """The planner `name`: a built-in (`centralized`, …), a planner an installed package
    registers (entry point group `cocobench.planners`), or code: `FILE.py:NAME` or
    `package.module:NAME`. User code is loaded once per process, so worker processes resolve
    the same string; the spec's `name` is the canonical reference (a file's absolute path)."""
    spec = PLANNERS.get(name)
    if spec is not None:
        return spec
    return load_planner(name).spec


def find_planner(text: str) -> str | None:
    """The canonical name of the planner that `text` names or whose condition code it is
    (`C0`, `LW`, an installed plugin's code), or None; raises `PlannerError` for code that
    fails to load."""
    by_code = {spec.code: name for name, spec in PLANNERS.items()}
    if text in by_code or text in PLANNERS:
        return by_code.get(text, text)
    return find_user_planner(text)


def planner_rounds(name: str) -> Rounds | None:
    """The round a planner declares as plain functions (`PlannerSpec.rounds`, built once
    per process), which episodes play directly; None for a planner that gives only a
    graph."""
    spec = planner_spec(name)
    if spec.rounds is None:
        return None
    cached = _ROUNDS.get(spec.name)
    if cached is None or cached[0] is not spec:
        cached = _ROUNDS[spec.name] = (spec, spec.rounds())
    return cached[1]


def compiled_graph(name: str):
    """The compiled graph of a planner (compiled once per process; no checkpointer)."""
    spec = planner_spec(name)
    cached = _COMPILED.get(spec.name)
    if cached is None or cached[0] is not spec:
        cached = _COMPILED[spec.name] = (spec, _compile(spec))
    return cached[1]


def build_planners(names: Iterable[str]) -> None:
    """Build each planner now, once for this process: a worker that does so before its
    first episode spends none of that episode's time on it (a graph-only strategy imports
    LangGraph and compiles, seconds on a busy machine, during which its loop is silent and
    a short --stall-timeout stops it as a runaway). A planner that declares its rounds is
    played without LangGraph, so only a graph-only one is compiled."""
    for name in dict.fromkeys(names):
        if planner_rounds(name) is None:
            compiled_graph(name)


def _compile(spec: PlannerSpec):
    from langgraph.graph import StateGraph

    from cocobench_agents.graphs.node_errors import checked_nodes

    graph = spec.build()
    if not isinstance(graph, StateGraph):
        raise PlannerError(f"planner {spec.name}: its build function returned a "
                           f"{type(graph).__name__}, not a langgraph StateGraph")
    if spec.name not in PLANNERS:  # a strategy's nodes: each update checked as returned
        checked_nodes(graph)
    return graph.compile()
