"""D0 / D1: one model per agent, all deciding on the same snapshot, landed in agent order.

With `broadcast` (D1) each agent may add a `MSG:` line that its teammates read next round.
"""

from __future__ import annotations

from collections.abc import Sequence
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
    history = state.get("history") or {}
    return [Send("decide_agent", {"agent": a, "history": history.get(a, []),
                                  "messages": state.get("messages") or [],
                                  "directive": (state.get("directives") or {}).get(a)})
            for a in state["agents"]]


def board(messages: Sequence[dict[str, Any]], directive: str | None) -> list[dict[str, Any]]:
    """What an agent's prompt shows on its message board: the posted messages and, under
    leader–worker, the leader's instruction to it last."""
    shown = list(messages)
    if directive:
        shown.append({"agent": "leader", "text": directive})
    return shown


def make_decide_agent(broadcast: bool):
    """The per-agent decision node (a branch of the round's fan-out)."""
    async def decide_agent(branch: dict[str, Any], runtime: Runtime[PlannerContext]
                           ) -> dict[str, Any]:
        messages = board(branch["messages"], branch.get("directive"))
        decision = await decide(runtime.context, branch["agent"], policy=POLICY,
                                history=branch["history"], messages=messages,
                                broadcast=broadcast or bool(branch.get("directive")))
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
