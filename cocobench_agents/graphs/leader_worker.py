"""Leader–worker: a strategy beyond the paper.

Each round a leader model, seeing the whole team (like a centralized planner), gives every
robot a one-line instruction; then every robot decides its own action in parallel, as in D1,
with the leader's instruction shown on its message board. It tests whether explicit
allocation by one model, with execution left to each agent, beats both C0 and D1.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.decentralized import branch_inputs, make_decide_agent
from cocobench_agents.graphs.decision import accepts_images
from cocobench_agents.graphs.model_calls import unrecorded
from cocobench_agents.graphs.nodes import land_round
from cocobench_agents.graphs.rounds import FanOut, Node, Rounds
from cocobench_agents.graphs.state import TEAM, PlannerState, team_history
from cocobench_agents.models.protocol import ModelError, ModelReply, ModelRequest
from cocobench_agents.prompts import history_line
from cocobench_agents.tools import EpisodeTools, prompt_hash, reply_fields

if TYPE_CHECKING:  # types only: the plain loop passes a `runtime.RoundRuntime`
    from langgraph.graph import StateGraph
    from langgraph.runtime import Runtime

POLICY = "leader"
DIRECTIVE = re.compile(r"^\s*(agent_\d+)\s*:\s*(.+?)\s*$", re.MULTILINE)


class LeaderWorkerState(PlannerState, total=False):
    """A leader–worker round's state: the shared state, and the leader's instructions."""

    directives: dict[str, str]  # the leader's instruction to each robot, this round


async def lead(state: LeaderWorkerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Ask the leader model for this round's instruction to each robot."""
    return {"directives": await ask_leader(runtime.context, team_history(state))}


def instructed(state: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The robots' decisions of the round (`branch_inputs`), each robot's board showing the
    posted messages and, last, the leader's instruction to it."""
    messages = state.get("messages") or []
    directives = state.get("directives") or {}
    return branch_inputs(state, {a: board(messages, directives.get(a))
                                 for a in state["agents"]})


def board(messages: Sequence[dict[str, Any]], directive: str | None) -> list[dict[str, Any]]:
    """What a robot's prompt shows on its message board: the posted messages and the
    leader's instruction to it last."""
    shown = list(messages)
    if directive:
        shown.append({"agent": "leader", "text": directive})
    return shown


async def ask_leader(ctx: PlannerContext, history: list[str]) -> dict[str, str]:
    """The leader model's instruction to each robot, given the team's `history`; recorded."""
    client = ctx.client_for(None)
    prompt, images = ctx.tools.leader_prompt(history, accepts_images(client))
    try:
        request = ModelRequest(prompt=prompt, images=images, sample_index=ctx.sample_index)
        reply = await ctx.retry_policy.complete(unrecorded(client), request)  # recorded below
    except ModelError as error:  # a silent leader leaves the workers on their own
        return record_directives(ctx.tools, client.name, prompt, error=error)
    return record_directives(ctx.tools, client.name, prompt, reply=reply)


def record_directives(tools: EpisodeTools, model: str, prompt: str, *,
                      reply: ModelReply | None = None, error: ModelError | None = None
                      ) -> dict[str, str]:
    """Record the leader's decision (its reply, or the error that silenced it) and return
    its instruction to each robot named in the reply (``agent_N: …`` lines, 200 characters
    each)."""
    record: dict[str, Any] = {"policy": POLICY, "model": model, "agent": None,
                              "step_index": tools.step_index, "status": "plan",
                              "terminal_reason": None, "prompt_hash": prompt_hash(prompt)}
    directives: dict[str, str] = {}
    if reply is not None:
        directives = {a: text[:200] for a, text in DIRECTIVE.findall(reply.text)
                      if a in tools.agents}
        record.update(reply_fields(reply), directives=directives)
    elif error is not None:
        record.update(status="backend_error", error=str(error), error_kind=error.kind)
    tools.record(record)
    return directives


async def remember_team(state: PlannerState, runtime: Runtime[PlannerContext]
                        ) -> dict[str, Any]:
    """Keep the team-wide history the leader reads, from the steps landed so far."""
    return {"history": {**(state.get("history") or {}),
                        TEAM: team_lines(runtime.context.tools)}}


def team_lines(tools: EpisodeTools) -> list[str]:
    """The team-wide history lines of the steps landed so far, oldest first."""
    return [history_line(i["label"], i["skill_result"]["success"],
                         i["skill_result"]["errorMessage"])
            for i in tools.episode.items if "skill_result" in i]


def leader_worker_rounds() -> Rounds:
    """team_history → lead → decide_agent × N (at once) → land_round (land, observe), until
    a terminal reason."""
    return Rounds((Node("team_history", remember_team), Node("lead", lead),
                   FanOut("decide_agent", instructed, make_decide_agent(broadcast=True)),
                   Node("land_round", land_round)), state=LeaderWorkerState)


def build_leader_worker() -> StateGraph:
    """The graph of `leader_worker_rounds`: team_history → lead → decide_agent × N →
    land_round → (team_history | END)."""
    return leader_worker_rounds().graph()
