"""A planner's round, declared once as plain async functions (`Rounds`), and the two ways it
is played: LangGraph's graph built from it (`Rounds.graph`: what Studio, `langgraph dev` and
`compiled_graph` show and run), and `play_rounds`, a plain loop awaiting the same functions,
which is how an episode of a planner that declares its rounds (`PlannerSpec.rounds`) runs.

Why two: LangGraph's per-superstep machinery (channels, the Pregel loop, langchain_core's
callbacks, a task per node) was 52–70 % of a training environment's step and of a harness
decision. The loop keeps what the graph guarantees: the same node functions in the same order,
the state merged by the schema's reducers (`pending` collects), a fan-out's branches run at
once (a learner's seat is asked beside its teammates, `envs/turns.py`), a node's exception
noted with the node's name as LangGraph notes it (`node_errors.node_failure`), and a bound on
the supersteps (`EndlessLoop`).

Imports no LangGraph until a graph is built or a round is played: `node_errors` reads this
module's file, and the CLI's light paths import that.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import typing
from collections import deque
from collections.abc import Awaitable, Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from cocobench_agents.graphs.state import PlannerState

if TYPE_CHECKING:
    from langgraph.graph import StateGraph

#: A node's function, as LangGraph calls it: (state or branch input, runtime) → the update.
NodeFunction = Callable[[Any, Any], Awaitable[Mapping[str, Any] | None]]


@dataclass(frozen=True)
class Node:
    """A step of the round: `run(state, runtime)` returns the state update."""

    name: str
    run: NodeFunction


@dataclass(frozen=True)
class FanOut:
    """A step run once per input that `branches(state)` gives, all branches at once (the
    graph's `Send`s): `run(branch, runtime)` returns each branch's update, merged in branch
    order. The step after it takes them all (LangGraph's fan-in)."""

    name: str
    branches: Callable[[Mapping[str, Any]], Sequence[Mapping[str, Any]]]
    run: NodeFunction


@dataclass(frozen=True)
class Rounds:
    """A planner's round: its steps in order, repeated until a node sets `terminal_reason`
    (checked before every step that does not follow a fan-out, as the graph's routers do)."""

    steps: tuple[Node | FanOut, ...]
    state: type = PlannerState  # the graph's state schema; its reducers merge updates

    def __post_init__(self) -> None:
        names = [step.name for step in self.steps]
        if not names or len(set(names)) != len(names):
            raise ValueError(f"a round needs steps with distinct names, not {names}")
        for step, following in zip(self.steps, (*self.steps[1:], self.steps[0])):
            if isinstance(step, FanOut) and not isinstance(following, Node):
                raise ValueError(f"fan-out {step.name!r} must be followed by a node that "
                                 "takes its branches' updates")

    def node_function(self, name: str) -> NodeFunction | None:
        """The function of step `name` (for errors that name where it is defined)."""
        return next((step.run for step in self.steps if step.name == name), None)

    def graph(self) -> StateGraph:
        """The LangGraph graph of these steps: each step a node; into a step, a router that
        ends the graph once `terminal_reason` is set (into a fan-out: its `Send`s), except
        after a fan-out, whose branches all feed the next step."""
        from langgraph.graph import START, StateGraph

        from cocobench_agents.graphs.context import PlannerContext

        graph = StateGraph(self.state, context_schema=PlannerContext)
        for step in self.steps:
            graph.add_node(step.name, step.run)
        for index, step in enumerate(self.steps):
            before = self.steps[index - 1]  # the last step for the first: the next round
            if isinstance(before, FanOut):
                graph.add_edge(before.name, step.name)
            else:
                graph.add_conditional_edges(before.name, _router(step), _targets(step))
        first = self.steps[0]
        graph.add_conditional_edges(START, _router(first), _targets(first))
        return graph


def _targets(step: Node | FanOut) -> list[str]:
    from langgraph.graph import END

    return [step.name, END]


def _router(step: Node | FanOut):
    """END once a terminal reason is set, else `step` (a fan-out: one `Send` per branch).

    Async: LangGraph runs a sync router in a worker thread, a costly hop per step."""
    from langgraph.graph import END
    from langgraph.types import Send

    if isinstance(step, FanOut):
        async def fan_out(state):  # unannotated: LangGraph reads a router's hints as its input
            if state.get("terminal_reason"):
                return END
            return [Send(step.name, branch) for branch in step.branches(state)]
        return fan_out

    async def route(state):
        return END if state.get("terminal_reason") else step.name
    return route


# -- the plain loop ---------------------------------------------------------------------------


async def play_rounds(rounds: Rounds, state: Mapping[str, Any], context: Any, *, limit: int,
                      checked: bool = False) -> None:
    """Play `rounds` from `state` until a node sets `terminal_reason`, awaiting its functions
    directly; each step is one of LangGraph's supersteps, and more than `limit` of them raise
    `EndlessLoop` naming the last nodes. `checked`: each update is checked as the node
    returns it (a strategy's code; `node_errors.update_problem`)."""
    from cocobench_agents.graphs.node_errors import LAST_NODES, EndlessLoop
    from cocobench_agents.graphs.runtime import RoundRuntime

    runtime = RoundRuntime(context=context)
    reducers, defaults = _channels(rounds.state)
    values = {**defaults, **state}
    ran: deque[str] = deque(maxlen=LAST_NODES)
    supersteps, after_fan_out = 0, False
    while True:
        for step in rounds.steps:
            if not after_fan_out and values.get("terminal_reason"):
                return
            if supersteps >= limit:
                raise EndlessLoop(limit, list(ran), rounds)
            supersteps += 1
            if isinstance(step, FanOut):
                branches = step.branches(values)
                updates = await _fan_out(step, branches, runtime, checked)
                ran.extend(step.name for _ in branches)
            else:
                updates = (await _run(step, values, runtime, checked),)
                ran.append(step.name)
            for update in updates:
                _merge(values, update, reducers)
            after_fan_out = isinstance(step, FanOut)


async def _fan_out(step: FanOut, branches: Sequence[Mapping[str, Any]], runtime: Any,
                   checked: bool) -> Sequence[Mapping[str, Any] | None]:
    """Every branch's update, the branches run at once; when one raises, the others are
    cancelled (as LangGraph cancels a failed superstep's other tasks)."""
    tasks = [asyncio.ensure_future(_run(step, branch, runtime, checked)) for branch in branches]
    try:
        return await asyncio.gather(*tasks)
    finally:
        for task in tasks:
            # Not on a closed loop: an abandoned environment's episode is closed by the
            # garbage collector after its loop (cancel would raise 'Event loop is closed').
            if not task.done() and not task.get_loop().is_closed():
                task.cancel()


async def _run(step: Node | FanOut, value: Any, runtime: Any, checked: bool
               ) -> Mapping[str, Any] | None:
    """One call of a step's function; an exception leaves noted with the node's name, as
    LangGraph notes it (`node_errors.node_failure` reads the note)."""
    try:
        update = await step.run(value, runtime)
    except Exception as exc:
        exc.add_note(f"During task with name '{step.name}'")
        raise
    if update is not None and (checked or not isinstance(update, Mapping)):
        _check(step, update)
    return update


def _check(step: Node | FanOut, update: Any) -> None:
    from cocobench_agents.graphs.node_errors import MalformedUpdate, update_problem

    problem = update_problem(update) or (
        None if isinstance(update, Mapping) else
        f"it returned a {type(update).__name__}, not a dict of state updates (a round's "
        "functions return dicts; LangGraph's Command needs a graph)")
    if problem is not None:
        raise MalformedUpdate(problem, step.name, step.run)


def _merge(values: dict[str, Any], update: Mapping[str, Any] | None,
           reducers: Mapping[str, Callable[[Any, Any], Any]]) -> None:
    """Apply a node's update as LangGraph's channels do: a reducer's key folds the new value
    into the old one, any other key is replaced."""
    for key, value in (update or {}).items():
        reducer = reducers.get(key)
        values[key] = reducer(values.get(key), value) if reducer is not None else value


@functools.cache
def _channels(schema: type) -> tuple[dict[str, Callable[[Any, Any], Any]], dict[str, Any]]:
    """The reducers of `schema`'s keys (``Annotated[T, reducer]``) and the value each such key
    starts with (an empty ``T``, as LangGraph's channel starts)."""
    reducers: dict[str, Callable[[Any, Any], Any]] = {}
    defaults: dict[str, Any] = {}
    for key, hint in typing.get_type_hints(schema, include_extras=True).items():
        reducer = next((m for m in reversed(getattr(hint, "__metadata__", ())) if callable(m)),
                       None)
        if reducer is None:
            continue
        reducers[key] = reducer
        base = typing.get_origin(hint.__origin__) or hint.__origin__
        with contextlib.suppress(TypeError):  # a type with no empty value starts unset
            defaults[key] = base()
    return reducers, defaults
