"""Claim-board: robots claim what they will work on before anyone acts.

Each round the robots decide one after another, in team order, each reading the board: last
rounds' messages plus the claims teammates made earlier in this round. A robot's choice claims
the object it works on (finding, picking up, opening, slicing … it; putting, dropping,
exploring and waiting claim nothing). A robot whose choice targets an object a teammate
claimed this round is asked once more, with the conflict on the board; if it insists, it
idles this round. Then the round's calls land in team order (`land_round`, as in D0/D1) and
every claim is posted as its step's message.

Against D1 (simultaneous decisions, messages a round late) it tests whether seeing teammates'
intentions before choosing prevents duplicated work; against leader–worker, whether that
needs a leader at all.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from cocobench_agents.graphs import (
    Node,
    PlannerContext,
    PlannerState,
    Rounds,
    decide,
    land_round,
)

if TYPE_CHECKING:  # types only: an episode of these rounds runs without LangGraph
    from langgraph.graph import StateGraph
    from langgraph.runtime import Runtime

POLICY = "claim_board"
BOARD = "board"  # the author of the board's own notes (a conflict)
CLAIMS_NOTHING = frozenset({"Put", "Drop", "Explore", "Wait"})


def claimed_object(call: str | None) -> str | None:
    """The object a call works on, which it claims: `PickUp(agent_1, Apple|1|2|3)` →
    `Apple|1|2|3`; None for calls that claim nothing."""
    if not call:
        return None
    skill, _, rest = call.partition("(")
    if skill in CLAIMS_NOTHING:
        return None
    return next((arg for arg in rest.rstrip(")").split(", ")[1:] if "|" in arg), None)


async def claim_round(state: PlannerState, runtime: Runtime[PlannerContext]
                      ) -> dict[str, Any]:
    """Every robot in turn decides and claims; the round's decisions go to `land_round`."""
    ctx = runtime.context
    board = list(state.get("messages") or [])  # earlier rounds' posts, then this round's
    claims: dict[str, str] = {}  # object → the robot that claimed it this round
    pending = []
    for agent in state["agents"]:
        history = (state.get("history") or {}).get(agent, [])
        decision = await decide(ctx, agent, policy=POLICY, history=history, messages=board,
                                broadcast=True)
        owner = claims.get(claimed_object(decision["parsed_call"]) or "")
        if owner is not None:  # asked once more, with the conflict in front of it
            pending.append(_conflict(decision, owner))  # land_round records it, in order
            board.append({"agent": BOARD, "text": f"{agent}: {_label(ctx, decision)} is "
                                                   f"claimed by {owner}; choose another"})
            decision = await decide(ctx, agent, policy=POLICY, history=history,
                                    messages=board, broadcast=True)
            owner = claims.get(claimed_object(decision["parsed_call"]) or "")
            if owner is not None:  # it insists: it idles this round
                decision = _conflict(decision, owner)
        target = claimed_object(decision["parsed_call"])
        if target is not None:
            claims[target] = agent
            claim = f"claims: {_label(ctx, decision)}"
            board.append({"agent": agent, "text": claim})
            decision["message"] = "; ".join(filter(None, (claim, decision.get("message"))))
        pending.append(decision)
    return {"pending": pending}


def _conflict(decision: dict[str, Any], owner: str) -> dict[str, Any]:
    """A decision whose call is not landed: its object is a teammate's this round."""
    return {**decision, "status": "claim_conflict", "parsed_call": None,
            "wanted_call": decision["parsed_call"], "claimed_by": owner,
            "terminal_reason": None}


def _label(ctx: PlannerContext, decision: dict[str, Any]) -> str:
    """What a call does, as the menu words it ("pick up the Apple")."""
    call = decision["parsed_call"]
    names = {e.call: e.name for e in ctx.tools.snapshot.action_menu}
    return names.get(call, call).partition(": ")[2] or call


def claim_board_rounds() -> Rounds:
    """claim_round → land_round (land, then observe), until a terminal reason."""
    return Rounds((Node("claim_round", claim_round), Node("land_round", land_round)))


def build_claim_board() -> StateGraph:
    """The graph of `claim_board_rounds`: claim_round → land_round → (claim_round | END)."""
    return claim_board_rounds().graph()
