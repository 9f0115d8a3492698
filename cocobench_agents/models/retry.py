"""`RetryPolicy`: how a planner's decide node retries a model call that failed transiently.

The policy is an object of the planner's context (see `graphs.PlannerContext`), built from the
run-level options (`--max-retries`, backoff) and replaceable by a strategy. Retrying is
tenacity's job; a client only makes one attempt at a time (`attempt`), raising a `ModelError`
that says whether it is transient and whether the server asked for a pause (Retry-After).
"""

from __future__ import annotations

import random
import time
from dataclasses import dataclass, replace
from typing import Any, Protocol, runtime_checkable

from tenacity import AsyncRetrying, RetryCallState, retry_if_exception, stop_after_attempt

from .protocol import ModelClient, ModelError, ModelReply, ModelRequest
from .settings import ModelSettings

_SPENT = ("prompt_tokens", "completion_tokens", "cost_usd")


@runtime_checkable
class AttemptingClient(Protocol):
    """A client whose calls can fail transiently: it answers one attempt at a time."""

    name: str

    async def attempt(self, request: ModelRequest, number: int) -> ModelReply:
        """Attempt `number` (1-based) at `request`; raise `ModelError` on failure."""
        ...


@dataclass(frozen=True)
class RetryPolicy:
    """Retries of transient model failures: at most `max_attempts` attempts, with full-jitter
    exponential backoff ``random(0, min(backoff_max_s, backoff_s × 2^(n-1)))`` after failed
    attempt n, and never less than the server's Retry-After (capped at `backoff_max_s`).

    A reply or final error accounts for every attempt: `retries` is attempts − 1, `latency_s`
    runs from the first attempt to the end (backoff included), tokens and cost add up every
    attempt that got an answer.
    """

    max_attempts: int = 3
    backoff_s: float = 1.0
    backoff_max_s: float = 30.0

    @classmethod
    def from_settings(cls, settings: ModelSettings) -> RetryPolicy:
        """The policy the run-level options ask for."""
        return cls(max_attempts=settings.max_attempts, backoff_s=settings.backoff_s,
                   backoff_max_s=settings.backoff_max_s)

    async def complete(self, client: ModelClient, request: ModelRequest) -> ModelReply:
        """`client`'s answer to `request`, retrying transient failures; clients that cannot
        fail transiently (the built-ins) are asked once."""
        # What `isinstance(client, AttemptingClient)` tells, without the Protocol check's
        # cost (every attribute looked up through typing: 2 % of a built-in's decision).
        if not callable(getattr(client, "attempt", None)):
            return await client.complete(request)
        start = time.perf_counter()
        spent = dict.fromkeys(_SPENT, 0)
        retrying = AsyncRetrying(stop=stop_after_attempt(self.max_attempts), wait=self._wait,
                                 retry=retry_if_exception(_is_transient), reraise=True)
        try:
            async for attempt in retrying:
                with attempt:
                    number = attempt.retry_state.attempt_number
                    try:
                        reply = await client.attempt(request, number)
                    except ModelError as error:
                        _add(spent, error.extra)
                        raise
        except ModelError as error:
            raise _final_error(error, number, time.perf_counter() - start, spent) from None
        return _final_reply(reply, number, time.perf_counter() - start, spent)

    def _wait(self, state: RetryCallState) -> float:
        ceiling = min(self.backoff_max_s, self.backoff_s * 2 ** (state.attempt_number - 1))
        wait = random.uniform(0, ceiling)
        error = state.outcome.exception() if state.outcome is not None else None
        hint = getattr(error, "retry_after_s", None)
        if hint is not None:
            wait = max(wait, min(hint, self.backoff_max_s))
        return wait


def _is_transient(exc: BaseException) -> bool:
    return isinstance(exc, ModelError) and exc.transient


def _add(spent: dict[str, Any], usage: dict[str, Any]) -> None:
    for key in _SPENT:
        spent[key] += usage.get(key) or 0


def _final_reply(reply: ModelReply, attempts: int, latency_s: float,
                 spent: dict[str, Any]) -> ModelReply:
    if reply.cached:
        return reply  # as first obtained: no attempt was made now
    return replace(reply, retries=attempts - 1, latency_s=latency_s,
                   prompt_tokens=reply.prompt_tokens + spent["prompt_tokens"],
                   completion_tokens=reply.completion_tokens + spent["completion_tokens"],
                   cost_usd=reply.cost_usd + spent["cost_usd"])


def _final_error(error: ModelError, attempts: int, latency_s: float,
                 spent: dict[str, Any]) -> ModelError:
    message = error.message
    if error.transient:
        message += f" (after {attempts} attempt{'s' if attempts != 1 else ''})"
    return replace(error, message=message, retries=attempts - 1, latency_s=latency_s,
                   extra={**error.extra, "attempts": attempts, **spent})
