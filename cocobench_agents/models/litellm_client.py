"""`LiteLLMClient`: any model LiteLLM can reach (the default transport)."""

from __future__ import annotations

import asyncio
import functools
import os
from types import ModuleType
from typing import Any

from .litellm_errors import classify
from .remote import Completion, RemoteClient

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


class LiteLLMClient(RemoteClient):
    """A `ModelClient` for one LiteLLM model string (``openai/gpt-4o``,
    ``anthropic/claude-…``, ``openai/<name>`` with `api_base` for any OpenAI-compatible server).

    Retries, timeouts, the concurrency limit and the cache are `RemoteClient`'s; LiteLLM's own
    retries and cache are not used (its cache is broken on hits in 1.106).
    """

    transport = "litellm"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # Whether the cost map prices this model: asking again on every call of an unpriced
        # model costs milliseconds of CPU each time.
        self._priced = True

    async def send(self, messages: list[dict[str, Any]], params: dict[str, Any],
                   timeout_s: float) -> Completion:
        litellm = import_litellm()
        kwargs: dict[str, Any] = {
            **params,
            "model": self.model,
            "messages": messages,
            # Retries are ours alone: LiteLLM's and the OpenAI SDK's would multiply them.
            "num_retries": 0,
            "max_retries": 0,
            "timeout": timeout_s,
            # Providers that do not take a parameter (seed, temperature on o1…) get it dropped
            # instead of failing the call.
            "drop_params": True,
        }
        api_base, auth_headers = self.settings.endpoint()
        if api_base:
            kwargs["api_base"] = api_base
        if auth_headers:
            kwargs["extra_headers"] = {**(kwargs.get("extra_headers") or {}), **auth_headers}
        api_key = self.settings.call_key()
        if api_key:  # a key given in `extra_params` wins, as in the http transport
            kwargs.setdefault("api_key", api_key)
        # A backstop in case a provider ignores `timeout` (a hung stream must not hang a run).
        # Generous: it also counts LiteLLM's own set-up, seconds on a first call on a busy
        # machine, which must not turn into a spurious timeout.
        response = await asyncio.wait_for(litellm.acompletion(**kwargs),
                                          timeout_s + _BACKSTOP_GRACE_S)
        usage = getattr(response, "usage", None)
        return Completion(
            text=_reply_text(response),
            prompt_tokens=int(getattr(usage, "prompt_tokens", 0) or 0),
            completion_tokens=int(getattr(usage, "completion_tokens", 0) or 0),
            cost_usd=self._cost(litellm, response),
        )

    def classify(self, exc: BaseException) -> tuple[str, bool]:
        return classify(import_litellm(), exc)

    def _cost(self, litellm: ModuleType, response: Any) -> float:
        """The call's cost from LiteLLM's local cost map; 0 for models it has no price for."""
        # LiteLLM prices the call as it returns it (by the model asked for); compute it only
        # when it did not, first by the model the provider reports, then by the one asked for.
        hidden = getattr(response, "_hidden_params", None) or {}
        cost = hidden.get("response_cost") if isinstance(hidden, dict) else None
        if isinstance(cost, (int, float)) and cost >= 0:
            return float(cost)
        if self._priced:
            for kwargs in ({}, {"model": self.model}):
                try:
                    return float(
                        litellm.completion_cost(completion_response=response, **kwargs) or 0.0)
                except Exception:  # noqa: BLE001 - unknown models raise; cost never fails a call
                    continue
            self._priced = False
        return 0.0


def _reply_text(response: Any) -> str:
    choices = getattr(response, "choices", None) or []
    if not choices:
        return ""
    message = getattr(choices[0], "message", None)
    content = getattr(message, "content", None)
    return content if isinstance(content, str) else ""
