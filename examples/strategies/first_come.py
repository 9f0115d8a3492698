"""First come, first served: every robot decides at once, on the same snapshot (as in D1),
and reads the message board. When two robots choose to work on the same object, the first in
team order gets it; the other idles this round (its decision is recorded with status `taken`,
the call it wanted and who took the object) and the board tells the team next round.

Against D1 it asks whether refusing duplicated work within a round, with no extra model
call, is enough; against claim-board (robots decide in turn and are asked again), whether
asking again is worth its calls.

Written from docs/planners.md alone, as a template for a strategy in one file:

    cocobench planners examples/strategies/first_come.py:FIRST_COME --check
    cocobench run --planner examples/strategies/first_come.py:FIRST_COME --model greedy \
        --suite demo --out runs/first-come
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any

from benchmark_adapter.skills.calls import parse_call
from cocobench_agents.graphs import (
    Node,
    PlannerContext,
    PlannerSpec,
    PlannerState,
    Rounds,
    decide,
    land_round,
)

if TYPE_CHECKING:  # types only: an episode of these rounds runs without LangGraph
    from langgraph.graph import StateGraph
    from langgraph.runtime import Runtime

POLICY = "first_come"


def worked_on(call: str | None) -> str | None:
    """The object a call works on (its first object-id argument): `PickUp(agent_1,
    Apple|+01.00|+00.90|-00.25)` → that id; None for calls on no object (Explore, Wait)."""
    if not call:
        return None
    return next((arg for arg in parse_call(call).args if "|" in arg), None)


async def decide_all(state: PlannerState, runtime: Runtime[PlannerContext]
                     ) -> dict[str, Any]:
    """Every robot's decision on this round's snapshot, asked in parallel; a robot whose
    object a teammate earlier in team order took this round idles."""
    ctx = runtime.context
    history = state.get("history") or {}
    board = state.get("messages") or []
    decisions = await asyncio.gather(*(
        decide(ctx, agent, policy=POLICY, history=history.get(agent, []), messages=board,
               broadcast=True)
        for agent in state["agents"]))
    taken: dict[str, str] = {}  # object id → the robot that works on it this round
    notes = []
    pending = []
    for decision in decisions:
        target = worked_on(decision["parsed_call"])
        owner = taken.get(target) if target else None
        if owner is not None:
            # No call: land_round records it and idles this robot; terminal_reason None,
            # since the robot did not ask to stop.
            decision = {**decision, "status": "taken", "parsed_call": None,
                        "terminal_reason": None, "wanted_call": decision["parsed_call"],
                        "taken_by": owner}
            notes.append({"round": state.get("round_index", 1), "agent": "board",
                          "text": f"{decision['agent']} idled: {owner} works on "
                                  f"{target.partition('|')[0]}"})
        elif target is not None:
            taken[target] = decision["agent"]
        pending.append(decision)
    return {"pending": pending, "messages": [*board, *notes]}


def first_come_rounds() -> Rounds:
    """decide_all → land_round (land, then observe), until a terminal reason."""
    return Rounds((Node("decide_all", decide_all), Node("land_round", land_round)))


def build_first_come() -> StateGraph:
    """The graph of `first_come_rounds`: decide_all → land_round → (decide_all | END)."""
    return first_come_rounds().graph()


FIRST_COME = PlannerSpec(
    name="first-come",  # replaced by the reference it is loaded by
    code="FC",  # FC_image, FC_blind in --conditions, run folders and reports
    build=build_first_come,
    rounds=first_come_rounds,  # episodes await its round directly, without LangGraph
    decentralized=True,  # one model per agent (--agent-model works)
    uses_models=True,
    description="robots decide at once; of two choosing the same object, the first in "
                "team order gets it and the other idles this round",
    loop="round",  # every robot is asked once per round
    prompt="agent",  # each robot's own prompt
    broadcast=True,  # with the message board: the dry run counts it
)
