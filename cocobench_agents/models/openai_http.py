"""`OpenAIHTTPClient`: the ``http`` transport, a lean client of the OpenAI chat-completions API.

An explicit option (``--transport http``), not the default. LiteLLM spends ~9 ms of CPU on
every call here, so one process tops out near 100 calls/s; a sweep against a local vLLM or
llama.cpp server at high concurrency is then bound by the client, not the model. This client
posts the same messages straight to ``{api_base}/chat/completions`` over a kept-alive aiohttp
session (~0.5 ms per call). It speaks only the OpenAI API: no provider translation, no
parameter dropping; prices come from the cost map LiteLLM ships, looked up once per model,
and LiteLLM itself is never imported.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import os
from typing import Any

import orjson

from .failures import MalformedCompletion, is_context_window_message, status_kind
from .providers import litellm_cost_map
from .remote import Completion, RemoteClient
from .settings import ModelSettings

#: The model-spec prefix the transport accepts (as in LiteLLM, ``openai/NAME``).
OPENAI_PREFIX = "openai/"
OPENAI_API_BASE = "https://api.openai.com/v1"
#: Where the key comes from when no `api_key_env` is given (as LiteLLM's openai provider).
OPENAI_KEY_ENV = "OPENAI_API_KEY"


class HTTPStatusError(Exception):
    """The server answered with an error status."""

    def __init__(self, status_code: int, message: str, headers: Any = None) -> None:
        super().__init__(f"HTTP {status_code}: {message}")
        self.status_code = status_code
        self.message = message
        self.headers = headers  # for Retry-After


class OpenAIHTTPClient(RemoteClient):
    """A `ModelClient` for ``openai/NAME`` at `ModelSettings.api_base` (OpenAI's by default)."""

    transport = "http"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        api_base = self.settings.endpoint()[0]
        self.url = (api_base or OPENAI_API_BASE).rstrip("/") + "/chat/completions"
        self._headers = _headers(self.settings)
        self._session: Any = None  # one aiohttp session, for the event loop that opened it
        self._session_loop: asyncio.AbstractEventLoop | None = None
        self._session_keeper: asyncio.Task | None = None

    async def send(self, messages: list[dict[str, Any]], params: dict[str, Any],
                   timeout_s: float) -> Completion:
        import aiohttp

        body = {**params, "model": self.model.removeprefix(OPENAI_PREFIX), "messages": messages}
        # LiteLLM sends `extra_body` fields as top-level body fields, and `api_key` /
        # `extra_headers` as headers; so do we.
        body.update(body.pop("extra_body", None) or {})
        headers = self._headers
        if "api_key" in body or "extra_headers" in body:
            headers = {**headers, **_key_header(body.pop("api_key", None)),
                       **(body.pop("extra_headers", None) or {})}
        async with self._open_session().post(
            self.url, data=orjson.dumps(body), headers=headers,
            timeout=aiohttp.ClientTimeout(total=timeout_s),
        ) as response:
            raw = await response.read()
            if response.status >= 400:
                raise HTTPStatusError(response.status, _error_message(raw), response.headers)
        return self._completion(raw)

    def classify(self, exc: BaseException) -> tuple[str, bool]:
        import aiohttp

        if isinstance(exc, HTTPStatusError):
            if exc.status_code == 400 and is_context_window_message(exc.message):
                return "context_window", False
            return status_kind(exc.status_code)
        if isinstance(exc, TimeoutError):  # aiohttp's timeouts derive from it
            return "timeout", True
        if isinstance(exc, (aiohttp.ClientConnectionError, aiohttp.ClientPayloadError)):
            return "transient", True
        return "other", False

    async def aclose(self) -> None:
        keeper = self._session_keeper
        if keeper is not None and self._session_loop is asyncio.get_running_loop():
            keeper.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await keeper
        self._session = self._session_loop = self._session_keeper = None

    # -- helpers -----------------------------------------------------------------------------

    def _open_session(self) -> Any:
        import aiohttp

        loop = asyncio.get_running_loop()
        if self._session is None or self._session_loop is not loop or self._session.closed:
            # The semaphore bounds requests in flight; the connector keeps that many alive.
            connector = aiohttp.TCPConnector(limit=self.settings.max_concurrency)
            self._session = aiohttp.ClientSession(connector=connector)
            self._session_loop = loop
            # asyncio.run cancels leftover tasks before it closes its loop; this one then
            # closes the session inside that loop, so callers who never call aclose() (one
            # asyncio.run per episode, say) leave no connection open and get no warning.
            self._session_keeper = loop.create_task(_close_when_cancelled(self._session))
        return self._session

    def _completion(self, raw: bytes) -> Completion:
        try:
            data = _json(raw)
            message = data["choices"][0]["message"] if data.get("choices") else {}
            usage = data.get("usage") or {}
            prompt_tokens = int(usage.get("prompt_tokens") or 0)
            completion_tokens = int(usage.get("completion_tokens") or 0)
        except (ValueError, TypeError, KeyError, AttributeError, IndexError):
            raise MalformedCompletion(
                f"not a chat completion: {raw[:200].decode(errors='replace')!r}") from None
        content = message.get("content") if isinstance(message, dict) else None
        input_price, output_price = token_prices(self.model)
        return Completion(
            text=content if isinstance(content, str) else "",
            prompt_tokens=prompt_tokens,
            completion_tokens=completion_tokens,
            cost_usd=prompt_tokens * input_price + completion_tokens * output_price,
        )


def _headers(settings: ModelSettings) -> dict[str, str]:
    key = settings.call_key() or os.environ.get(OPENAI_KEY_ENV)
    # URL credentials (HTTP Basic) take the Authorization header over the key.
    return {"Content-Type": "application/json", **_key_header(key), **settings.endpoint()[1]}


def _key_header(key: str | None) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"} if key else {}


async def _close_when_cancelled(session: Any) -> None:
    try:
        await asyncio.get_running_loop().create_future()  # never set: waits for cancellation
    finally:
        await session.close()


def _json(raw: bytes) -> Any:
    """The JSON of a response body. orjson refuses a lone surrogate's escape (``\\ud800``),
    which the JSON standard allows and LiteLLM's parser takes: the standard library reads
    such a body, so both transports see the same reply (made writable by the client)."""
    try:
        return orjson.loads(raw)
    except orjson.JSONDecodeError as refused:
        try:
            return json.loads(raw)
        except RecursionError:  # nested past Python's limit too: orjson's refusal stands
            raise refused from None


def _error_message(raw: bytes) -> str:
    """The ``error.message`` of an OpenAI-style error body, or the body's start."""
    try:
        error = orjson.loads(raw).get("error")
        message = error.get("message") if isinstance(error, dict) else error
        if isinstance(message, str) and message:
            return message
    except (ValueError, AttributeError):
        pass
    return raw[:300].decode(errors="replace")


def preload(model: str) -> None:
    """Load what calls of `model` will need (aiohttp, its prices) now: before episodes start,
    and before worker processes fork, so that no first call pays for it."""
    import aiohttp  # noqa: F401

    token_prices(model)


@functools.cache
def token_prices(model: str) -> tuple[float, float]:
    """USD per (prompt, completion) token from LiteLLM's cost map; zeros if unpriced."""
    cost_map = litellm_cost_map()
    for name in (model, model.removeprefix(OPENAI_PREFIX)):
        entry = cost_map.get(name)
        if isinstance(entry, dict):
            return (float(entry.get("input_cost_per_token") or 0.0),
                    float(entry.get("output_cost_per_token") or 0.0))
    return 0.0, 0.0
