"""A sealed-bid auction: every robot's decision on the round's snapshot is its bid; robots
bidding for the same object are each asked a second question, the price (their cost, 1 to 5,
to work on it: the strategy's own prompt template, `pricing`); the lowest price wins the
object (ties: the first in team order) and the others idle this round as `outbid`.

It shows how a strategy makes a model call of its own: `ask` renders its template (declared
on its spec, so it is part of the prompt suite: `cocobench prompts export --planner`, a
suite folder's `pricing.txt` replaces it, the suite's hash covers it), sends it through the
run's retry policy and records it like a decision (usage, cost, the viewer's timeline):

    cocobench planners examples/strategies/sealed_bid.py:SEALED_BID --check
    cocobench run --planner examples/strategies/sealed_bid.py:SEALED_BID --model greedy \
        --suite demo --out runs/sealed-bid
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from benchmark_adapter.skills.calls import parse_call
from cocobench_agents.graphs import (
    Node,
    PlannerContext,
    PlannerSpec,
    PlannerState,
    Rounds,
    ask,
    decide,
    land_round,
)

if TYPE_CHECKING:  # types only: an episode of these rounds runs without LangGraph
    from langgraph.graph import StateGraph
    from langgraph.runtime import Runtime

POLICY = "sealed_bid"
PRICES = ("1", "2", "3", "4", "5")
PRICING = """You are {me}, one of {n} robots ({agents}).
GOAL: {goal}
{progress_section}
Teammates also want to work on the {object} this round; you chose: {wanted}.
What would it cost you to do it, from 1 (cheap: you are close, hands free) to 5 (dear)?
You hold: {inv}
{menu}
Reply on one line: ACTION: <the number of your price>
"""


def worked_on(call: str | None) -> str | None:
    """The object a call works on (its first object-id argument); None for calls on no
    object (Explore, Wait)."""
    if not call:
        return None
    return next((arg for arg in parse_call(call).args if "|" in arg), None)


async def bid_round(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict[str, Any]:
    """Every robot bids (its decision); each contested object goes to its lowest price."""
    ctx = runtime.context
    history = state.get("history") or {}
    bids = [await decide(ctx, agent, policy=POLICY, history=history.get(agent, []))
            for agent in state["agents"]]
    wanted: dict[str, list[int]] = {}  # object id → the bids for it, in team order
    for index, bid in enumerate(bids):
        target = worked_on(bid["parsed_call"])
        if target is not None:
            wanted.setdefault(target, []).append(index)
    for target, contested in wanted.items():
        if len(contested) > 1:
            await settle(ctx, bids, contested, target, history)
    return {"pending": bids}


async def settle(ctx: PlannerContext, bids: list[dict[str, Any]], contested: list[int],
                 target: str, history: dict[str, list[str]]) -> None:
    """Ask each contested bidder its price; all but the lowest are outbid."""
    prices = {}
    for index in contested:
        agent = bids[index]["agent"]
        answer = await ask(ctx, agent, "pricing", {
            "object": target.partition("|")[0], "wanted": bids[index]["parsed_call"]},
            menu=PRICES, history=history.get(agent, []))
        # No usable price (a parse error, a failed call): the highest.
        prices[index] = int(answer["answer"] or PRICES[-1])
    winner = min(contested, key=lambda index: prices[index])
    for index in contested:
        if index != winner:
            bids[index] = {**bids[index], "status": "outbid", "parsed_call": None,
                           "terminal_reason": None, "wanted_call": bids[index]["parsed_call"],
                           "outbid_by": bids[winner]["agent"], "price": prices[index]}


def sealed_bid_rounds() -> Rounds:
    """bid_round → land_round (land, then observe), until a terminal reason."""
    return Rounds((Node("bid_round", bid_round), Node("land_round", land_round)))


def build_sealed_bid() -> StateGraph:
    """The graph of `sealed_bid_rounds`: bid_round → land_round → (bid_round | END)."""
    return sealed_bid_rounds().graph()


SEALED_BID = PlannerSpec(
    name="sealed-bid",  # replaced by the reference it is loaded by
    code="SB",
    build=build_sealed_bid,
    rounds=sealed_bid_rounds,  # episodes await its round directly, without LangGraph
    decentralized=True,
    uses_models=True,
    description="robots bid with their decisions; a contested object goes to the lowest "
                "price, asked with a second call",
    loop="round",  # every robot bids once per round
    prompt="agent",
    calls_per_seat=2,  # its bid, and its price when its object is contested
    templates={"pricing": PRICING},  # its own prompt: part of the prompt suite
)
