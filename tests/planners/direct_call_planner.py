"""A strategy that calls its model around `decide` and `ask`: with the context's client and
retry policy directly, as a researcher may (test_strategy_calls.py)."""

from __future__ import annotations

import contextlib
from typing import Any

from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime

from cocobench_agents.graphs import (
    PlannerContext,
    PlannerSpec,
    PlannerState,
    continue_or_end,
    decide,
    land_round,
)
from cocobench_agents.models.protocol import ModelError, ModelRequest


async def consult_then_decide(state: PlannerState, runtime: Runtime[PlannerContext]
                              ) -> dict[str, Any]:
    """A free-text question to the team's model, its reply ignored, then every robot's
    decision."""
    ctx = runtime.context
    question = ModelRequest(prompt=f"Round {state.get('round_index')}: any advice?")
    with contextlib.suppress(ModelError):  # advice is optional
        await ctx.retry_policy.complete(ctx.client_for(None), question)
    return {"pending": [await decide(ctx, agent, policy="direct", history=[])
                        for agent in state["agents"]]}


def build_direct() -> StateGraph:
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("consult", consult_then_decide)
    graph.add_node("land_round", land_round)
    graph.add_edge(START, "consult")
    graph.add_edge("consult", "land_round")
    graph.add_conditional_edges("land_round", continue_or_end("consult"), ["consult", END])
    return graph


DIRECT = PlannerSpec("direct", "DC", build_direct, decentralized=False, uses_models=True,
                     description="asks its model a question directly, then decides as D0",
                     loop="round", prompt="agent", calls_per_seat=2)
