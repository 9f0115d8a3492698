"""The oracle as a planner: the cell's privileged reference plan, through the same run path."""

from __future__ import annotations

from typing import Any

from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.nodes import continue_or_end, observe_next
from cocobench_agents.graphs.state import PlannerState
from cocobench_agents.tools import stop_decision

POLICY = "oracle"


async def follow_plan(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Land the plan's next call (the plan gets the previous result back, as in the reference)."""
    ctx = runtime.context
    plan = ctx.oracle_plan
    try:
        last = ctx.last_result
        call = next(plan) if last is None else plan.send(last)
    except StopIteration:
        ctx.tools.stop(stop_decision(policy=POLICY, model=None, agent=None,
                                     step_index=ctx.tools.step_index, status="done"))
        return {"terminal_reason": "done"}
    ctx.last_result = ctx.tools.land(call)
    return observe_next(ctx, state)


def build_oracle() -> StateGraph:
    """follow_plan (land, then observe) → (follow_plan | END)."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("follow_plan", follow_plan)
    graph.add_edge(START, "follow_plan")
    graph.add_conditional_edges("follow_plan", continue_or_end("follow_plan"),
                                ["follow_plan", END])
    return graph
