"""Leader–worker: a strategy beyond the paper.

Each round a leader model, seeing the whole team (like a centralized planner), gives every
robot a one-line instruction; then every robot decides its own action in parallel, as in D1,
with the leader's instruction shown on its message board. It tests whether explicit
allocation by one model, with execution left to each agent, beats both C0 and D1.
"""

from __future__ import annotations

import re
from typing import Any

from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.decentralized import add_round, fan_out
from cocobench_agents.graphs.decision import accepts_images
from cocobench_agents.graphs.nodes import continue_or_end
from cocobench_agents.graphs.state import TEAM, PlannerState, team_history
from cocobench_agents.models.protocol import ModelError, ModelRequest
from cocobench_agents.prompts import history_line
from cocobench_agents.tools import prompt_hash, reply_fields

POLICY = "leader"
DIRECTIVE = re.compile(r"^\s*(agent_\d+)\s*:\s*(.+?)\s*$", re.MULTILINE)


async def lead(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Ask the leader model for this round's instruction to each robot."""
    ctx = runtime.context
    tools = ctx.tools
    client = ctx.client_for(None)
    prompt, images = tools.leader_prompt(team_history(state), accepts_images(client))
    record: dict[str, Any] = {"policy": POLICY, "model": client.name, "agent": None,
                              "step_index": tools.step_index, "status": "plan",
                              "terminal_reason": None, "prompt_hash": prompt_hash(prompt)}
    directives: dict[str, str] = {}
    try:
        request = ModelRequest(prompt=prompt, images=images, sample_index=ctx.sample_index)
        reply = await ctx.retry_policy.complete(client, request)
        directives = {a: text[:200] for a, text in DIRECTIVE.findall(reply.text)
                      if a in tools.agents}
        record.update(reply_fields(reply), directives=directives)
    except ModelError as error:  # a silent leader leaves the workers on their own
        record.update(status="backend_error", error=str(error), error_kind=error.kind)
    tools.record(record)
    return {"directives": directives}


async def remember_team(state: PlannerState, runtime: Runtime[PlannerContext]
                        ) -> dict[str, Any]:
    """Keep the team-wide history the leader reads, from the steps landed so far."""
    items = runtime.context.tools.episode.items
    lines = [history_line(i["label"], i["skill_result"]["success"],
                          i["skill_result"]["errorMessage"])
             for i in items if "skill_result" in i]
    return {"history": {**(state.get("history") or {}), TEAM: lines}}


def build_leader_worker() -> StateGraph:
    """team_history → lead → decide_agent × N → land_round (land, observe) → (… | END)."""
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    add_round(graph, broadcast=True)
    graph.add_node("team_history", remember_team)
    graph.add_node("lead", lead)
    graph.add_edge(START, "team_history")
    graph.add_edge("team_history", "lead")
    graph.add_conditional_edges("lead", fan_out, ["decide_agent", END])
    graph.add_conditional_edges("land_round", continue_or_end("team_history"),
                                ["team_history", END])
    return graph
