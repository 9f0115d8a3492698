"""C0: one planner sees every agent's view and menu and moves one agent per step."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.decision import decide
from cocobench_agents.graphs.nodes import observe_next
from cocobench_agents.graphs.rounds import Node, Rounds
from cocobench_agents.graphs.state import TEAM, PlannerState, team_history
from cocobench_agents.prompts import history_line

if TYPE_CHECKING:  # types only: the plain loop passes a `runtime.RoundRuntime`
    from langgraph.graph import StateGraph
    from langgraph.runtime import Runtime

POLICY = "centralized_vlm"


async def choose(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Ask the team's model for the next action of one agent."""
    return {"pending": [await decide(runtime.context, None, policy=POLICY,
                                     history=team_history(state))]}


async def act(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Land the chosen call (`land_decision`)."""
    return land_decision(runtime.context, state, state["pending"][0])


def land_decision(ctx: PlannerContext, state: PlannerState, decision: dict[str, Any]
                  ) -> dict[str, Any]:
    """Record the step's decision and land its call; any decision without a call ends the
    episode (no re-prompt). The state update."""
    tools = ctx.tools
    tools.record(decision, model_call=decision["status"] != "no_actions")
    call = decision["parsed_call"]
    if not call:
        tools.stop(decision)
        return {"pending": None, "terminal_reason": decision["terminal_reason"]}
    result = tools.land(call, decision=decision)
    team = [*team_history(state), history_line(call, result.success, result.errorMessage)]
    return {"pending": None, "history": {TEAM: team}, **observe_next(ctx, state)}


def centralized_rounds() -> Rounds:
    """choose → act (land, then observe), until a terminal reason."""
    return Rounds((Node("choose", choose), Node("act", act)))


def build_centralized() -> StateGraph:
    """The graph of `centralized_rounds`: choose → act → (choose | END)."""
    return centralized_rounds().graph()
