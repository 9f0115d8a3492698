"""D0 / D1: one model per agent, all deciding on the same snapshot, landed in agent order.

With `broadcast` (D1) each agent may add a `MSG:` line that its teammates read next round.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.decision import decide
from cocobench_agents.graphs.nodes import land_round
from cocobench_agents.graphs.rounds import FanOut, Node, Rounds
from cocobench_agents.graphs.runtime import END
from cocobench_agents.graphs.state import PlannerState

if TYPE_CHECKING:  # types only: the plain loop passes a `runtime.RoundRuntime`
    from langgraph.graph import StateGraph
    from langgraph.runtime import Runtime
    from langgraph.types import Send

POLICY = "distributed_vlm"


async def fan_out(state: PlannerState) -> list[Any] | str:
    """One `decide_agent` branch per agent (LangGraph's `Send`s), each with only what that
    agent may know (a router for a strategy's own graph; `decentralized_rounds` declares the
    built-ins'). Its hints name no LangGraph type: LangGraph reads a router's hints, and this
    module imports LangGraph only where a graph is built."""
    if state.get("terminal_reason"):
        return END
    return round_branches(state, state.get("messages") or [])


def round_branches(state: PlannerState, boards: Sequence[dict[str, Any]] | Mapping[
        str, Sequence[dict[str, Any]]]) -> list[Send]:
    """The round's `decide_agent` branches (`branch_inputs`) as LangGraph's `Send`s."""
    from langgraph.types import Send

    return [Send("decide_agent", branch) for branch in branch_inputs(state, boards)]


def branch_inputs(state: Mapping[str, Any], boards: Sequence[dict[str, Any]] | Mapping[
        str, Sequence[dict[str, Any]]]) -> list[dict[str, Any]]:
    """What each agent's `decide_agent` branch of the round gets: its history and message
    board (one board for all, or each agent's by name: a strategy may show each robot its
    own note)."""
    history = state.get("history") or {}
    return [{"agent": a, "history": history.get(a, []),
             "messages": boards.get(a, []) if isinstance(boards, Mapping) else boards}
            for a in state["agents"]]


def board_branches(state: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The round's branches, every agent reading the one message board."""
    return branch_inputs(state, state.get("messages") or [])


def make_decide_agent(broadcast: bool):
    """The per-agent decision node (a branch of the round's fan-out)."""
    async def decide_agent(branch: dict[str, Any], runtime: Runtime[PlannerContext]
                           ) -> dict[str, Any]:
        decision = await decide(runtime.context, branch["agent"], policy=POLICY,
                                history=branch["history"], messages=branch["messages"],
                                broadcast=broadcast)
        return {"pending": [decision]}
    return decide_agent


def decentralized_rounds(broadcast: bool = False) -> Rounds:
    """decide_agent × N (at once) → land_round (land, then observe), until a terminal
    reason."""
    return Rounds((FanOut("decide_agent", board_branches, make_decide_agent(broadcast)),
                   Node("land_round", land_round)))


def build_decentralized(broadcast: bool = False) -> StateGraph:
    """The graph of `decentralized_rounds`: decide_agent × N (parallel) → land_round →
    (next round | END)."""
    return decentralized_rounds(broadcast).graph()


def add_round(graph: StateGraph, *, broadcast: bool) -> None:
    """The decide_agent and land_round nodes; the caller wires what starts a round (a
    strategy may add a step before the fan-out)."""
    graph.add_node("decide_agent", make_decide_agent(broadcast))
    graph.add_node("land_round", land_round)
    graph.add_edge("decide_agent", "land_round")
