"""A planner's episode played until it waits for its learners: the learning seats' model
clients (`SeatClient`) park each request as an `Ask`, which the environment answers with the
seat's action; `PlannerTurns.until_waiting` runs the event loop until the planner has ended
or can go no further without those answers.

A planner may ask its seats all at once (D0's fan-out) or one after another, each ask
depending on the last answer (claim-board), so "waiting for learners" is not a count of
asks: it is the event loop having nothing left to do but wait for them — no callback
ready, no partner's model call under way, no worker thread busy.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
from dataclasses import dataclass, field
from typing import Any

from cocobench_agents.models.protocol import ModelClient, ModelError, ModelReply, ModelRequest
from cocobench_agents.models.retry import RetryPolicy

#: How long to wait before looking again while a partner's call or a worker thread is busy.
POLL_S = 0.0005


@dataclass
class Ask:
    """A learning seat's pending decision: what its model would have been sent."""

    seat: str
    request: ModelRequest
    reply: asyncio.Future[ModelReply]


@dataclass
class PlannerTurns:
    """The learners' pending asks of one episode, and what else its planner is doing."""

    asks: dict[str, Ask] = field(default_factory=dict)
    partner_calls: int = 0  # partners' model calls under way

    def ask(self, seat: str, request: ModelRequest) -> asyncio.Future[ModelReply]:
        """Park `seat`'s request; the future its client awaits."""
        if seat in self.asks:
            raise ModelError("bad_request", f"seat {seat!r} was asked twice at once; a "
                             "planner asks one seat one decision at a time")
        reply = asyncio.get_running_loop().create_future()
        self.asks[seat] = Ask(seat, request, reply)
        return reply

    def answer(self, seat: str, text: str) -> None:
        """Answer `seat`'s pending ask with the reply text `text`."""
        self.asks.pop(seat).reply.set_result(ModelReply(text=text))

    def cancel(self) -> None:
        """Withdraw every pending ask (the episode is abandoned)."""
        for ask in self.asks.values():
            ask.reply.cancel()
        self.asks.clear()

    async def until_waiting(self, played: asyncio.Future[Any]) -> None:
        """Run until `played` (the episode's task) is done or it waits on learners only;
        a `RuntimeError` when it waits on nothing this side answers."""
        loop = asyncio.get_running_loop()
        quiet = 0
        while not played.done():
            # Timers count only while nobody is asked: a partner's retry pause then holds
            # the planner, while libraries' own timers (LiteLLM's) never end.
            if _ready(loop) or self.partner_calls or _threads_busy(loop) or (
                    not self.asks and _timers(loop)):
                quiet = 0
                await asyncio.sleep(0 if _ready(loop) else POLL_S)
            elif quiet < 2:  # twice, so that a worker thread's late callback is seen
                quiet += 1
                await asyncio.sleep(0)
            elif self.asks:
                return
            else:
                raise RuntimeError("the planner waits on something other than its seats' "
                                   "model calls")


class SeatClient:
    """A learning seat's model client: each request waits for the seat's action."""

    accepts_images = False  # the environment shows frames itself (`SeatedEpisode.frame`)

    def __init__(self, seat: str, name: str, turns: PlannerTurns) -> None:
        self.seat, self.name, self.turns = seat, name, turns

    async def complete(self, request: ModelRequest) -> ModelReply:
        return await self.turns.ask(self.seat, request)


class PartnerClient:
    """A partner seat's client, counted while its call is under way: its retries too, so
    it makes them itself (under the planner's policy) and offers no single attempts."""

    def __init__(self, client: ModelClient, turns: PlannerTurns, retry: RetryPolicy) -> None:
        self.client, self.turns, self.retry = client, turns, retry
        self.name = client.name
        self.accepts_images = getattr(client, "accepts_images", True)

    async def complete(self, request: ModelRequest) -> ModelReply:
        self.turns.partner_calls += 1
        try:
            return await self.retry.complete(self.client, request)
        finally:
            self.turns.partner_calls -= 1


class NoSeatClient:
    """The client behind a key the planner's declared seats do not name (the team's model of
    a planner whose loop asks every robot): asking it is the planner's mistake."""

    accepts_images = False

    def __init__(self, name: str, planner: str, seats: list[str]) -> None:
        self.name, self._planner, self._seats = name, planner, seats

    async def complete(self, request: ModelRequest) -> ModelReply:
        who = request.agent or "the team"
        raise ModelError("bad_request", f"planner {self._planner} asked {who}, which none of "
                         f"its declared seats ({', '.join(self._seats)}) is: declare its "
                         "loop on its spec (docs/planners.md)")


class CountingExecutor(concurrent.futures.ThreadPoolExecutor):
    """The environment loop's default executor: it knows whether a worker thread is busy
    (LangGraph runs a planner's synchronous nodes and routers in one)."""

    def __init__(self) -> None:
        super().__init__(thread_name_prefix="cocobench-env")
        self._lock = threading.Lock()
        self.busy = 0

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[override]
        with self._lock:
            self.busy += 1
        future = super().submit(fn, *args, **kwargs)
        future.add_done_callback(self._done)
        return future

    def _done(self, _: concurrent.futures.Future) -> None:
        with self._lock:
            self.busy -= 1


def new_loop() -> asyncio.AbstractEventLoop:
    """An event loop for environments' episodes, its worker threads counted."""
    loop = asyncio.new_event_loop()
    loop.set_default_executor(CountingExecutor())
    return loop


# The loop's private queues: asyncio has no public "is anything ready" (CPython's
# BaseEventLoop keeps ready callbacks in `_ready`, timers in `_scheduled`).
def _ready(loop: asyncio.AbstractEventLoop) -> bool:
    return bool(getattr(loop, "_ready", ()))


def _timers(loop: asyncio.AbstractEventLoop) -> bool:
    return any(not timer.cancelled() for timer in getattr(loop, "_scheduled", ()))


def _threads_busy(loop: asyncio.AbstractEventLoop) -> bool:
    executor = getattr(loop, "_default_executor", None)
    return bool(getattr(executor, "busy", 0))
