"""D0 / D1: one model per agent, all deciding on the same snapshot, landed in agent order.

With `broadcast` (D1) each agent may add a `MSG:` line that its teammates read next round.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime
from langgraph.types import Send

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.decision import decide
from cocobench_agents.graphs.nodes import land_round
from cocobench_agents.graphs.state import PlannerState

POLICY = "distributed_vlm"


async def fan_out(state: PlannerState) -> list[Send] | str:
    """One `decide_agent` branch per agent, each with only what that agent may know."""
    if state.get("terminal_reason"):
        return END
    return round_branches(state, state.get("messages") or [])


def round_branches(state: PlannerState, boards: Sequence[dict[str, Any]] | Mapping[
        str, Sequence[dict[str, Any]]]) -> list[Send]:
    """The round's `decide_agent` branches: each agent's history and message board (one
    board for all, or each agent's by name: a strategy may show each robot its own note)."""
    history = state.get("history") or {}
    return [Send("decide_agent", {"agent": a, "history": history.get(a, []),
                                  "messages": boards.get(a, []) if isinstance(boards, Mapping)
                                  else boards})
            for a in state["agents"]]


def make_decide_agent(broadcast: bool):
    """The per-agent decision node (a branch of the round's fan-out)."""
    async def decide_agent(branch: dict[str, Any], runtime: Runtime[PlannerContext]
                           ) -> dict[str, Any]:
        decision = await decide(runtime.context, branch["agent"], policy=POLICY,
                                history=branch["history"], messages=branch["messages"],
                                broadcast=broadcast)
        return {"pending": [decision]}
    return decide_agent


def build_decentralized(broadcast: bool = False) -> StateGraph:
    """decide_agent × N (parallel) → land_round (land, then observe) → (next round | END)."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    add_round(graph, broadcast=broadcast)
    graph.add_conditional_edges(START, fan_out, ["decide_agent", END])
    graph.add_conditional_edges("land_round", fan_out, ["decide_agent", END])
    return graph


def add_round(graph: StateGraph, *, broadcast: bool) -> None:
    """The decide_agent and land_round nodes; the caller wires what starts a round (a
    strategy may add a step before the fan-out)."""
    graph.add_node("decide_agent", make_decide_agent(broadcast))
    graph.add_node("land_round", land_round)
    graph.add_edge("decide_agent", "land_round")
