"""Nodes shared by the planner graphs: observing, landing a round, routing."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.runtime import END
from cocobench_agents.graphs.state import PlannerState
from cocobench_agents.prompts import history_line
from cocobench_agents.tools import stop_decision

if TYPE_CHECKING:  # a type only: the plain loop passes a `runtime.RoundRuntime`
    from langgraph.runtime import Runtime


def observe_next(ctx: PlannerContext, state: PlannerState) -> dict[str, Any]:
    """After landing: stop on the step budget, else take the next step's (or round's) snapshot.

    Called at the end of the landing nodes rather than as a node of its own: every superstep
    costs LangGraph overhead, and the first snapshot is taken when the episode starts.
    """
    if ctx.budget_spent():
        ctx.tools.stop(stop_decision(policy="harness", model=None, agent=None,
                                     step_index=ctx.tools.step_index, status="max_steps"))
        return {"terminal_reason": "max_steps"}
    ctx.tools.refresh()
    return {"round_index": state.get("round_index", 0) + 1}


async def land_round(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Land the round's decisions (`land_decisions`)."""
    return land_decisions(runtime.context, state, state.get("pending") or [])


def land_decisions(ctx: PlannerContext, state: PlannerState, pending: list[dict[str, Any]]
                   ) -> dict[str, Any]:
    """Record a round's decisions in agent order, then land their calls in that order; the
    state update. The round rule of every round-loop planner (the training environments
    play the planner's graph, so this rule too: `cocobench_agents.envs`).

    A round in which nobody acts ends the episode, recorded with the last agent's decision
    (the reference's rule). The budget can cut a round short; messages of agents whose
    call landed are posted to the board.
    """
    tools = ctx.tools
    order = {a: i for i, a in enumerate(tools.agents)}
    decisions = sorted(pending, key=lambda d: order.get(d.get("agent"), -1))
    for d in decisions:
        tools.record(d, model_call=d["status"] != "no_actions")
    if not any(d["parsed_call"] for d in decisions):
        stop = decisions[-1] if decisions else stop_decision(
            policy="harness", model=None, agent=None, step_index=tools.step_index,
            status="all_idle")
        tools.stop(stop)
        return {"pending": None, "terminal_reason": stop["terminal_reason"] or "all_idle"}
    round_index = state.get("round_index", 0)
    history = {a: list(h) for a, h in (state.get("history") or {}).items()}
    posted = []
    for d in decisions:
        if not d["parsed_call"]:
            continue
        if ctx.budget_spent():
            break
        result = tools.land(d["parsed_call"], decision=d, round_index=round_index,
                            message=d.get("message") or None)
        history.setdefault(d["agent"], []).append(
            history_line(d["parsed_call"], result.success, result.errorMessage))
        if d.get("message"):
            posted.append({"round": round_index, "agent": d["agent"], "text": d["message"]})
    tools.episode.post_messages(posted)
    return {"pending": None, "history": history,
            "messages": [*(state.get("messages") or []), *posted], **observe_next(ctx, state)}


def continue_or_end(next_node: str):
    """A router: END once a terminal reason is set, else `next_node`.

    Routers are async: LangGraph runs a sync router in a worker thread, a costly hop per step.
    """
    async def route(state: PlannerState) -> str:
        return END if state.get("terminal_reason") else next_node
    return route
