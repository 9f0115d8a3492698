"""`LiteLLMClient`: any model LiteLLM can reach, with retries, timeouts, a concurrency limit,
a response cache and token/cost accounting."""

from __future__ import annotations

import asyncio
import functools
import os
import random
import time
import weakref
from types import ModuleType
from typing import Any

from tenacity import AsyncRetrying, RetryCallState, retry_if_exception, stop_after_attempt

from .cache import ResponseCache, cache_key
from .grammar import menu_grammar, wants_message
from .litellm_errors import EmptyCompletion, classify, retry_after_s, status_code
from .messages import build_messages, cap_reply
from .protocol import ModelError, ModelReply, ModelRequest
from .secrets import redact
from .settings import ModelSettings

_MAX_ERROR_CHARS = 600  # provider error bodies can be long; a record needs the gist
_BACKSTOP_GRACE_S = 30.0


@functools.cache
def import_litellm() -> ModuleType:
    """Import LiteLLM on first use (it takes seconds), offline and quiet."""
    # Without this LiteLLM fetches its model cost map from the network at import time.
    os.environ.setdefault("LITELLM_LOCAL_MODEL_COST_MAP", "True")
    import litellm

    # No "Give Feedback / Get Help" banners or provider lists printed on errors.
    litellm.suppress_debug_info = True
    return litellm


class LiteLLMClient:
    """A `ModelClient` for one LiteLLM model string (``openai/gpt-4o``,
    ``anthropic/claude-…``, ``openai/<name>`` with `api_base` for any OpenAI-compatible server).

    Transient failures (rate limits, timeouts, connection errors, 5xx, empty completions) are
    retried with jittered exponential backoff, attempt n with an HTTP timeout of
    ``timeout_s × n``; client errors fail fast. Every failure ends as a `ModelError` whose
    message never contains a key. LiteLLM's own retries and cache are not used (its cache is
    broken on hits in 1.106).

    A reply's `latency_s` runs from the first attempt to the answer (retries and backoff
    included, queueing for the concurrency limit not); its tokens and cost add up every
    attempt that got an answer (empty ones too). A cache hit returns the stored reply as it
    was first obtained, with ``cached=True``.
    """

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

    async def complete(self, request: ModelRequest) -> ModelReply:
        """Answer `request` (from the cache when possible); raise `ModelError` otherwise."""
        messages = build_messages(request)
        params = self.call_params(request)
        key = None
        if self.cache is not None:
            key = cache_key(self.model, messages, params, request.sample_index)
            hit = self.cache.get(key)
            if hit is not None:
                return hit
        async with self._semaphore():
            reply = await self._call(messages, params)
        if self.cache is not None and key is not None:
            self.cache.put(key, reply, model=self.model, sample_index=request.sample_index)
        return reply

    def _semaphore(self) -> asyncio.Semaphore:
        loop = asyncio.get_running_loop()
        sem = self._semaphores.get(loop)
        if sem is None:
            # LiteLLM's Router rejects requests over its limit; a semaphore queues them.
            sem = self._semaphores[loop] = asyncio.Semaphore(self.settings.max_concurrency)
        return sem

    # -- the call, with retries --------------------------------------------------------------

    async def _call(self, messages: list[dict[str, Any]], params: dict[str, Any]) -> ModelReply:
        litellm = import_litellm()
        s = self.settings
        start = time.perf_counter()
        spent = {"prompt_tokens": 0, "completion_tokens": 0, "cost_usd": 0.0}
        attempts = 0
        retrying = AsyncRetrying(
            stop=stop_after_attempt(s.max_attempts),
            wait=self._wait,
            retry=retry_if_exception(lambda exc: classify(litellm, exc)[1]),
            reraise=True,
        )
        try:
            async for attempt in retrying:
                with attempt:
                    attempts = attempt.retry_state.attempt_number
                    response = await self._attempt(litellm, messages, params, attempts)
                    self._account(litellm, response, spent)
                    text = _reply_text(response)
                    if not text.strip():
                        raise EmptyCompletion("the model returned an empty completion")
        except Exception as exc:  # noqa: BLE001 - every failure must become a ModelError
            raise self._error(litellm, exc, attempts, time.perf_counter() - start, spent) from None
        text, _ = cap_reply(text, s.max_reply_chars)
        return ModelReply(
            text=text,
            prompt_tokens=spent["prompt_tokens"],
            completion_tokens=spent["completion_tokens"],
            cost_usd=spent["cost_usd"],
            latency_s=time.perf_counter() - start,
            retries=attempts - 1,
            cached=False,
        )

    async def _attempt(
        self, litellm: ModuleType, messages: list[dict[str, Any]], params: dict[str, Any], n: int
    ) -> Any:
        s = self.settings
        timeout = s.timeout_s * n  # the reference's "180 s × attempt number"
        kwargs: dict[str, Any] = {
            **params,
            "model": self.model,
            "messages": messages,
            # Retries are ours alone: LiteLLM's and the OpenAI SDK's would multiply them.
            "num_retries": 0,
            "max_retries": 0,
            "timeout": timeout,
            # Providers that do not take a parameter (seed, temperature on o1…) get it dropped
            # instead of failing the call.
            "drop_params": True,
        }
        if s.api_base:
            kwargs["api_base"] = s.api_base
        api_key = s.call_key()
        if api_key:
            kwargs["api_key"] = api_key
        # A backstop in case a provider ignores `timeout` (a hung stream must not hang a run).
        # Generous: it also counts LiteLLM's own set-up, seconds on a first call on a busy
        # machine, which must not turn into a spurious timeout.
        backstop = timeout + _BACKSTOP_GRACE_S
        return await asyncio.wait_for(litellm.acompletion(**kwargs), backstop)

    def _wait(self, state: RetryCallState) -> float:
        """Full-jitter exponential backoff, at least the server's Retry-After (capped)."""
        s = self.settings
        ceiling = min(s.backoff_max_s, s.backoff_s * 2 ** (state.attempt_number - 1))
        wait = random.uniform(0, ceiling)
        exc = state.outcome.exception() if state.outcome is not None else None
        hint = retry_after_s(exc) if exc is not None else None
        if hint is not None:
            wait = max(wait, min(hint, s.backoff_max_s))
        return wait

    def _account(self, litellm: ModuleType, response: Any, spent: dict[str, Any]) -> None:
        usage = getattr(response, "usage", None)
        spent["prompt_tokens"] += int(getattr(usage, "prompt_tokens", 0) or 0)
        spent["completion_tokens"] += int(getattr(usage, "completion_tokens", 0) or 0)
        spent["cost_usd"] += _cost(litellm, response, self.model)

    def _error(
        self,
        litellm: ModuleType,
        exc: BaseException,
        attempts: int,
        latency_s: float,
        spent: dict[str, Any],
    ) -> ModelError:
        kind, transient = classify(litellm, exc)
        detail = str(exc).strip().replace("\n", " ")
        if len(detail) > _MAX_ERROR_CHARS:
            detail = detail[:_MAX_ERROR_CHARS] + "…"
        message = f"{self.model}: {type(exc).__name__}: {detail}"
        if transient:
            message += f" (after {attempts} attempt{'s' if attempts != 1 else ''})"
        extra: dict[str, Any] = {"attempts": attempts, "exception": type(exc).__name__, **spent}
        status = status_code(exc)
        if status is not None:
            extra["status_code"] = status
        return ModelError(
            kind=kind,
            message=redact(message, [self.settings.api_key()]),
            retries=max(0, attempts - 1),
            latency_s=latency_s,
            extra=extra,
        )


def _reply_text(response: Any) -> str:
    choices = getattr(response, "choices", None) or []
    if not choices:
        return ""
    message = getattr(choices[0], "message", None)
    content = getattr(message, "content", None)
    return content if isinstance(content, str) else ""


def _cost(litellm: ModuleType, response: Any, model: str) -> float:
    """The call's cost from LiteLLM's local cost map; 0 for models it has no price for."""
    # LiteLLM prices the call as it returns it (by the model asked for); compute it only when
    # it did not, first by the model the provider reports, then by the one asked for.
    hidden = getattr(response, "_hidden_params", None) or {}
    cost = hidden.get("response_cost") if isinstance(hidden, dict) else None
    if isinstance(cost, (int, float)) and cost >= 0:
        return float(cost)
    for kwargs in ({}, {"model": model}):
        try:
            return float(litellm.completion_cost(completion_response=response, **kwargs) or 0.0)
        except Exception:  # noqa: BLE001 - unknown models raise; cost never fails a call
            continue
    return 0.0
