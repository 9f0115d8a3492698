"""The oracle as a planner: the cell's privileged reference plan, through the same run path."""

from __future__ import annotations

import weakref
from collections.abc import Generator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from benchmark_adapter.oracles import oracle_plan
from benchmark_adapter.skills import SkillResult
from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.nodes import observe_next
from cocobench_agents.graphs.rounds import Node, Rounds
from cocobench_agents.graphs.state import PlannerState
from cocobench_agents.tools import EpisodeTools, stop_decision

if TYPE_CHECKING:  # types only: the plain loop passes a `runtime.RoundRuntime`
    from langgraph.graph import StateGraph
    from langgraph.runtime import Runtime

POLICY = "oracle"


@dataclass
class _Plan:
    """Where an episode stands in its reference plan: a live generator, so it lives beside
    the episode's tools rather than in the graph's (plain, serialisable) state."""

    calls: Generator[str, SkillResult | None, None]
    last_result: SkillResult | None = field(default=None)  # what the previous call did


#: Each episode's plan, made on its first step and gone with its tools.
_PLANS: weakref.WeakKeyDictionary[EpisodeTools, _Plan] = weakref.WeakKeyDictionary()


def _plan_of(tools: EpisodeTools) -> _Plan:
    plan = _PLANS.get(tools)
    if plan is None:
        plan = _PLANS[tools] = _Plan(oracle_plan(tools.config))
    return plan


async def follow_plan(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Land the plan's next call (the plan gets the previous result back, as in the reference)."""
    ctx = runtime.context
    plan = _plan_of(ctx.tools)
    try:
        last = plan.last_result
        call = next(plan.calls) if last is None else plan.calls.send(last)
    except StopIteration:
        ctx.tools.stop(stop_decision(policy=POLICY, model=None, agent=None,
                                     step_index=ctx.tools.step_index, status="done"))
        return {"terminal_reason": "done"}
    plan.last_result = ctx.tools.land(call)
    return observe_next(ctx, state)


def oracle_rounds() -> Rounds:
    """follow_plan (land, then observe), until the plan ends or the budget is spent."""
    return Rounds((Node("follow_plan", follow_plan),))


def build_oracle() -> StateGraph:
    """The graph of `oracle_rounds`: follow_plan → (follow_plan | END)."""
    return oracle_rounds().graph()
