"""The oracle as a planner: the cell's privileged reference plan, through the same run path."""

from __future__ import annotations

from typing import Any

from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.nodes import continue_or_end, observe
from cocobench_agents.graphs.state import PlannerState
from cocobench_agents.tools import stop_decision

POLICY = "oracle"


async def follow_plan(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Land the plan's next call (the plan gets the previous result back, as in the reference)."""
    ctx = runtime.context
    plan = ctx.oracle_plan
    try:
        last = ctx.extra.get("last_result")
        call = next(plan) if last is None else plan.send(last)
    except StopIteration:
        ctx.tools.stop(stop_decision(policy=POLICY, model=None, agent=None,
                                     step_index=ctx.tools.step_index, status="done"))
        return {"terminal_reason": "done"}
    ctx.extra["last_result"] = ctx.tools.land(call)
    return {}


def build_oracle() -> StateGraph:
    """observe → follow_plan → (observe | END)."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("observe", observe)
    graph.add_node("follow_plan", follow_plan)
    graph.add_edge(START, "observe")
    graph.add_conditional_edges("observe", continue_or_end("follow_plan"), ["follow_plan", END])
    graph.add_conditional_edges("follow_plan", continue_or_end("observe"), ["observe", END])
    return graph
