"""Planners written outside the package, as a researcher writes them, for test_plugins.py:
one that works (as a function and as a `PlannerSpec`), and one of each mistake the pre-run
check must catch."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime

from cocobench_agents.graphs import (
    PlannerContext,
    PlannerSpec,
    PlannerState,
    RetryPolicy,
    continue_or_end,
    decide,
    land_round,
    observe_next,
)


async def step(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Ask the team's model and land its call, in one node."""
    ctx = runtime.context
    decision = ctx.tools.record(await decide(ctx, None, policy="one_node", history=[]))
    if not decision["parsed_call"]:
        ctx.tools.stop(decision)
        return {"terminal_reason": decision["terminal_reason"]}
    ctx.tools.land(decision["parsed_call"], decision=decision)
    return observe_next(ctx, state)


def build_one_node() -> StateGraph:
    """A centralized planner in one node."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("step", step)
    graph.add_edge(START, "step")
    graph.add_conditional_edges("step", continue_or_end("step"), ["step", END])
    return graph


ONE_NODE = PlannerSpec("one-node", "ON", build_one_node, decentralized=False,
                       uses_models=True, description="one node, no retries",
                       retry_policy=RetryPolicy(max_attempts=1))

# -- mistakes --------------------------------------------------------------------------------

NOT_A_PLANNER = 42
BAD_CODE = PlannerSpec("bad", "C0", build_one_node, False, True, "takes centralized's code")


def build_not_a_graph() -> dict:
    return {"nodes": ["step"]}


def build_raises() -> StateGraph:
    raise RuntimeError("no graph today")


async def idle(state: PlannerState) -> dict[str, Any]:
    return {}


def build_never_ends() -> StateGraph:
    """Loops without ever checking the step budget."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("idle", idle)
    graph.add_edge(START, "idle")
    graph.add_edge("idle", "idle")
    return graph


async def land_once(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    ctx = runtime.context
    decision = ctx.tools.record(await decide(ctx, None, policy="once", history=[]))
    ctx.tools.land(decision["parsed_call"], decision=decision)
    return {}


def build_no_terminal_reason() -> StateGraph:
    """Ends after one step without recording why."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("land_once", land_once)
    graph.add_edge(START, "land_once")
    graph.add_edge("land_once", END)
    return graph


@dataclass
class OtherContext:
    episode: str


def build_wrong_context() -> StateGraph:
    graph = build_one_node()
    graph.context_schema = OtherContext
    return graph


async def crash(state: PlannerState) -> dict[str, Any]:
    raise KeyError("agent_9")


def build_crashes() -> StateGraph:
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("crash", crash)
    graph.add_edge(START, "crash")
    graph.add_edge("crash", END)
    return graph


def seat_of(agent: str) -> int:
    seats = {"agent_1": 0, "agent_2": 1}  # written for teams of two: agent_3 has no seat
    return seats[agent]


async def seated_step(state: PlannerState, runtime: Runtime[PlannerContext]
                      ) -> dict[str, Any]:
    """Seat every agent, then step as one_node does."""
    [seat_of(agent) for agent in state["agents"]]
    return await step(state, runtime)


def build_crashes_on_three() -> StateGraph:
    """Passes the check (a team of two), raises in a team of three."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("seated_step", seated_step)
    graph.add_edge(START, "seated_step")
    graph.add_conditional_edges("seated_step", continue_or_end("seated_step"),
                                ["seated_step", END])
    return graph


BAD_LOOP = PlannerSpec("bad-loop", "BL", build_one_node, False, True, "a loop nobody knows",
                       loop="rounds")
BAD_SHAPE = PlannerSpec("bad-shape", "BS", build_one_node, False, True, "team prompt, rounds",
                        loop="round", prompt="team")
BAD_CALLS = PlannerSpec("bad-calls", "BK", build_one_node, True, True, "asks nobody",
                        loop="round", calls_per_seat=0)


# -- a strategy's bugs that only a team of three meets (the check's team has two) ------------


async def bid_without_status(state: PlannerState, runtime: Runtime[PlannerContext]
                             ) -> dict[str, Any]:
    """Every robot bids; in a team of three the last bid's record loses its status."""
    ctx = runtime.context
    pending = [await decide(ctx, agent, policy="bids", history=[])
               for agent in state["agents"]]
    if len(state["agents"]) == 3:
        del pending[-1]["status"]
    return {"pending": pending}


def build_malformed_on_three() -> StateGraph:
    """Returns its round's decisions to the framework's land_round."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("bid", bid_without_status)
    graph.add_node("land_round", land_round)
    graph.add_edge(START, "bid")
    graph.add_edge("bid", "land_round")
    graph.add_conditional_edges("land_round", continue_or_end("bid"), ["bid", END])
    return graph


async def stall_with_three(state: PlannerState, runtime: Runtime[PlannerContext]
                           ) -> dict[str, Any]:
    """Steps as one_node does; a team of three waits for a seat that never frees."""
    if len(state["agents"]) == 3:
        return {}
    return await step(state, runtime)


def build_endless_on_three() -> StateGraph:
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("stall_with_three", stall_with_three)
    graph.add_edge(START, "stall_with_three")
    graph.add_conditional_edges("stall_with_three", continue_or_end("stall_with_three"),
                                ["stall_with_three", END])
    return graph
