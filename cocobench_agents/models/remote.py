"""`RemoteClient`: what every client of a model behind HTTP shares (the request parameters,
the cache, the concurrency limit, retries with backoff, accounting and error records); a
transport subclass only sends one attempt and says what its failures mean."""

from __future__ import annotations

import asyncio
import re
import time
import weakref
from dataclasses import dataclass
from typing import Any, ClassVar

from .cache import ResponseCache, cache_key
from .failures import (
    EmptyCompletion,
    MalformedCompletion,
    is_unsupported_input_message,
    retry_after_s,
    status_code,
)
from .grammar import menu_grammar, wants_message
from .messages import build_messages, cap_reply
from .protocol import ModelError, ModelReply, ModelRequest
from .retry import RetryPolicy
from .secrets import redact
from .settings import ModelSettings

_MAX_ERROR_CHARS = 600  # provider error bodies can be long; a record needs the gist
_LONE_SURROGATE = re.compile("[\ud800-\udfff]")


@dataclass(frozen=True)
class Completion:
    """One attempt's answer, as a transport read it."""

    text: str
    prompt_tokens: int = 0
    completion_tokens: int = 0
    cost_usd: float = 0.0


class RemoteClient:
    """A `ModelClient` for one model string behind HTTP.

    One `attempt` sends one request, attempt n with an HTTP timeout of ``timeout_s × n``.
    Rate limits, timeouts, connection errors, 5xx, empty or malformed completions are
    transient failures, which a `RetryPolicy` retries; client errors are not. Every failure
    is a `ModelError` whose message never contains a key; its `extra` carries the tokens and
    cost the attempt spent (an empty answer still costs). A cache hit returns the stored
    reply as it was first obtained, with ``cached=True``.
    """

    transport: ClassVar[str]  # the `ModelSettings.transport` value naming this client

    def __init__(
        self,
        model: str,
        settings: ModelSettings | None = None,
        *,
        cache: ResponseCache | None = None,
    ) -> None:
        self.name = model
        self.model = model
        self.settings = settings if settings is not None else ModelSettings()
        if cache is None and self.settings.cache_dir is not None:
            cache = ResponseCache(self.settings.cache_dir)
        self.cache = cache
        # One semaphore per event loop: an asyncio primitive must not cross loops.
        self._semaphores: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, asyncio.Semaphore]
        self._semaphores = weakref.WeakKeyDictionary()

    # -- what a transport provides -----------------------------------------------------------

    async def send(self, messages: list[dict[str, Any]], params: dict[str, Any],
                   timeout_s: float) -> Completion:
        """One attempt; raise on any failure (`classify` then says what it was)."""
        raise NotImplementedError

    def classify(self, exc: BaseException) -> tuple[str, bool]:
        """``(ModelError kind, transient)`` for an exception `send` raised."""
        raise NotImplementedError

    async def aclose(self) -> None:
        """Release connections held for the running event loop (none by default)."""

    # -- the request -------------------------------------------------------------------------

    def call_params(self, request: ModelRequest) -> dict[str, Any]:
        """The parameters that shape the answer (sent with the call and part of the cache
        key): temperature, max_tokens, seed, `extra_params`, and the grammar if any."""
        s = self.settings
        params: dict[str, Any] = dict(s.extra_params)
        temperature = s.temperature_for(self.model)
        if temperature is not None:
            params["temperature"] = temperature
        if s.max_tokens is not None:
            params["max_tokens"] = s.max_tokens
        if s.seed is not None:
            # Repeated samples of one prompt must differ yet stay reproducible.
            params["seed"] = s.seed + request.sample_index
        if s.grammar:
            extra_body = dict(params.get("extra_body") or {})
            extra_body["grammar"] = menu_grammar(
                request.menu, with_msg=wants_message(request.prompt)
            )
            params["extra_body"] = extra_body
        return params

    def cache_scope(self) -> dict[str, Any]:
        """What shapes a stored reply besides the request itself (part of the cache key):
        the transport, the endpoint, and the cap the reply was cut to."""
        s = self.settings
        return {"transport": self.transport, "api_base": (s.api_base or "").rstrip("/") or None,
                "max_reply_chars": s.max_reply_chars}

    async def complete(self, request: ModelRequest) -> ModelReply:
        """Answer `request` under the run-level retry policy; raise `ModelError` otherwise.
        (A planner applies its own `RetryPolicy` to `attempt` instead.)"""
        return await RetryPolicy.from_settings(self.settings).complete(self, request)

    async def attempt(self, request: ModelRequest, number: int) -> ModelReply:
        """Attempt `number` at `request` (from the cache when possible): HTTP timeout
        ``timeout_s × number`` (the reference's "180 s × attempt number"); every failure
        raises a `ModelError` saying whether it is transient."""
        messages = build_messages(request)
        params = self.call_params(request)
        key = None
        if self.cache is not None:
            key = cache_key(self.model, messages, params, request.sample_index,
                            endpoint=self.cache_scope())
            hit = self.cache.get(key)
            if hit is not None:
                return hit
        async with self._semaphore():  # held for the attempt only, not for the backoff
            reply = await self._send_once(messages, params, number)
        if key is not None:  # set only when there is a cache
            self.cache.put(key, reply, model=self.model, sample_index=request.sample_index)
        return reply

    def _semaphore(self) -> asyncio.Semaphore:
        loop = asyncio.get_running_loop()
        sem = self._semaphores.get(loop)
        if sem is None:
            # Over a limit, providers (and LiteLLM's Router) reject; a semaphore queues.
            sem = self._semaphores[loop] = asyncio.Semaphore(self.settings.max_concurrency)
        return sem

    async def _send_once(self, messages: list[dict[str, Any]], params: dict[str, Any],
                         number: int) -> ModelReply:
        s = self.settings
        start = time.perf_counter()
        spent = {"prompt_tokens": 0, "completion_tokens": 0, "cost_usd": 0.0}
        try:
            completion = await self.send(messages, params, s.timeout_s * number)
            spent.update(prompt_tokens=completion.prompt_tokens,
                         completion_tokens=completion.completion_tokens,
                         cost_usd=completion.cost_usd)
            if not completion.text.strip():
                raise EmptyCompletion("the model returned an empty completion")
        except Exception as exc:  # noqa: BLE001 - every failure must become a ModelError
            raise self._error(exc, time.perf_counter() - start, spent) from None
        text, dropped = cap_reply(writable_text(completion.text), s.max_reply_chars)
        return ModelReply(text=text, latency_s=time.perf_counter() - start,
                          truncated_chars=dropped, **spent)

    def _kind(self, exc: BaseException) -> tuple[str, bool]:
        if isinstance(exc, EmptyCompletion):
            return "empty", True
        if isinstance(exc, MalformedCompletion):
            return "transient", True
        if is_unsupported_input_message(str(exc)):  # whatever its status: permanent
            return "unsupported_input", False
        return self.classify(exc)

    def _error(self, exc: BaseException, latency_s: float, spent: dict[str, Any]
               ) -> ModelError:
        kind, transient = self._kind(exc)
        detail = writable_text(str(exc)).strip().replace("\n", " ")
        if len(detail) > _MAX_ERROR_CHARS:
            detail = detail[:_MAX_ERROR_CHARS] + "…"
        message = f"{self.model}: {type(exc).__name__}: {detail}"
        extra: dict[str, Any] = {"exception": type(exc).__name__, **spent}
        status = status_code(exc)
        if status is not None:
            extra["status_code"] = status
        return ModelError(kind=kind, message=redact(message, self.settings.secrets()),
                          latency_s=latency_s, extra=extra, transient=transient,
                          retry_after_s=retry_after_s(exc))


def writable_text(text: str) -> str:
    """`text` with each lone surrogate replaced by U+FFFD: a server's JSON escape such as
    ``\\ud800`` decodes to one, and no UTF-8 file (a trajectory, the cache) can hold it, so
    a reply is made writable where it enters and judged by parsing like any other."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return _LONE_SURROGATE.sub("\ufffd", text)
    return text
