"""Planted runaways: planners that behave on every instance but one, where `hog` allocates
without bound and `spin` computes without yielding (as the embedded simulator's containment
cycle once did), and `slow` waits (yielding) before its first decision. Each runaway gives up
by itself after `GIVE_UP_S`, so a broken executor fails its test instead of taking the
machine down."""

from __future__ import annotations

import asyncio
import time

from langgraph.graph import END, START, StateGraph

from cocobench_agents.graphs import (
    PlannerContext,
    PlannerState,
    continue_or_end,
    decide,
    land_round,
)

RUNAWAY_TASK = "K_D3__DemoKitchen1__seed0"  # of the demo suite; the planner check uses another
SLOW_TASK = "J_D4__DemoBedroom2__seed0"  # the demo suite's longest budget: started first
GIVE_UP_S = 60.0
HOG_CEILING = 6 << 30  # bytes: past this the hog stops growing and spins


def _hog() -> None:
    held, since = [], time.monotonic()
    while time.monotonic() - since < GIVE_UP_S:
        if len(held) * (16 << 20) < HOG_CEILING:
            held.append(b"x" * (16 << 20))  # written, so resident
        time.sleep(0.005)
    raise RuntimeError("the hog was never stopped")


def _spin() -> None:
    since = time.monotonic()
    while time.monotonic() - since < GIVE_UP_S:
        pass
    raise RuntimeError("the spinner was never stopped")


SLOW_S = 3.0


async def _wait() -> None:
    await asyncio.sleep(SLOW_S)


def _build(misbehave, task: str = RUNAWAY_TASK) -> StateGraph:
    async def choose(state: PlannerState, runtime) -> dict:
        ctx: PlannerContext = runtime.context
        if ctx.tools.config.task_id == task and ctx.tools.step_index == 0:
            result = misbehave()
            if asyncio.iscoroutine(result):
                await result
        agent = state["agents"][state.get("round_index", 1) % len(state["agents"])]
        history = (state.get("history") or {}).get(agent, [])
        return {"pending": [await decide(ctx, agent, policy="round_robin", history=history)]}

    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("choose", choose)
    graph.add_node("land_round", land_round)
    graph.add_edge(START, "choose")
    graph.add_edge("choose", "land_round")
    graph.add_conditional_edges("land_round", continue_or_end("choose"), ["choose", END])
    return graph


def hog() -> StateGraph:
    """Allocates without bound on `RUNAWAY_TASK`."""
    return _build(_hog)


def spin() -> StateGraph:
    """Never yields on `RUNAWAY_TASK`."""
    return _build(_spin)


def slow() -> StateGraph:
    """Waits `SLOW_S` seconds (yielding) before its first decision on `SLOW_TASK`."""
    return _build(_wait, SLOW_TASK)
