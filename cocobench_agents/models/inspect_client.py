"""`InspectClient`: the ``inspect`` transport, decisions made by the model of a running
Inspect eval (``inspect eval cocobench_agents/cocobench``; see docs/inspect.md).

Each decision is one `Model.generate` of Inspect: its providers, retries, response cache,
usage limits and cost accounting apply, and the call is a model event in the sample's
transcript. The team's model is Inspect's model of the sample (`get_model()`); an agent
whose name is an Inspect model role (``--model-role agent_2=…``) decides with that role's
model. Inspect has already retried an error that reaches us, so every failure is final here:
the decision becomes a ``backend_error`` and the episode an infrastructure failure.

`inspect_ai` is imported only when a call is made, never with this module.
"""

from __future__ import annotations

import contextvars
import dataclasses
import sys
from typing import Any

from .errors import ModelConfigError
from .failures import is_context_window_message, status_code, status_kind
from .openai_http import token_prices
from .protocol import EpisodeHalt, ModelReply, ModelRequest
from .remote import Completion, RemoteClient
from .secrets import redact

#: The deciding agent of the call in flight (a contextvar: `send` does not get the request).
_AGENT: contextvars.ContextVar[str | None] = contextvars.ContextVar("cocobench_agent",
                                                                   default=None)
#: Whether Inspect served the call in flight from its response cache (set by `send`).
_FROM_CACHE: contextvars.ContextVar[bool] = contextvars.ContextVar("cocobench_from_cache",
                                                                  default=False)
_OUTSIDE = ("the inspect transport decides with the model of a running Inspect eval: run "
            "`inspect eval cocobench_agents/cocobench --model PROVIDER/MODEL` (docs/inspect.md)")


def check_inspect_eval(spec: str) -> None:
    """Raise `ModelConfigError` unless an Inspect eval is running here (`cocobench run
    --transport inspect` has no Inspect model to ask)."""
    running = sys.modules.get("inspect_ai.model._model")  # never imported here for the check
    if running is None or running.active_model() is None:
        raise ModelConfigError(spec, _OUTSIDE)


def inspect_model(agent: str | None) -> Any:
    """The Inspect model deciding for `agent` (None: the team): the model role named after
    the agent when the eval defines one, else the eval's model."""
    from inspect_ai.model import get_model

    check_inspect_eval("inspect")
    role = role_model(agent) if agent else None
    return role if role is not None else get_model()


def role_model(agent: str) -> Any:
    """The model of the running eval's Inspect model role named `agent` (the first, where a
    list is assigned to the role); None where the eval defines no such role."""
    from inspect_ai.model import model_roles

    role = model_roles().get(agent)
    if isinstance(role, list):
        role = role[0] if role else None
    return role


class InspectClient(RemoteClient):
    """A `ModelClient` that asks Inspect's model of the running sample."""

    transport = "inspect"

    def __init__(self, *args: Any, inspect_model: Any = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.cache = None  # Inspect's own cache applies, not ours
        # a given Inspect `Model` instead of the eval's (the pre-flight's own instance)
        self.inspect_model = inspect_model

    async def attempt(self, request: ModelRequest, number: int) -> ModelReply:
        token, from_cache = _AGENT.set(request.agent), _FROM_CACHE.set(False)
        try:
            reply = await super().attempt(request, number)
            # a reply of Inspect's cache is a cached reply, as one of ours: billed 0, its
            # first cost kept as saved
            return dataclasses.replace(reply, cached=True) if _FROM_CACHE.get() else reply
        finally:
            _AGENT.reset(token)
            _FROM_CACHE.reset(from_cache)

    async def send(self, messages: list[dict[str, Any]], params: dict[str, Any],
                   timeout_s: float) -> Completion:
        from inspect_ai.log import transcript
        from inspect_ai.model import GenerateConfig

        model = self.inspect_model or inspect_model(_AGENT.get())
        before = transcript().history.event_count  # this call's events come after
        output = await model.generate(chat_messages(messages),
                                      config=GenerateConfig(**generate_config(params)))
        if output.error:  # a refusal or content filter the provider reported as such
            raise InspectOutputError(output.error)
        _FROM_CACHE.set(served_from_cache(output, since=before))
        usage = output.usage
        return Completion(
            text=output.completion or "",
            prompt_tokens=prompt_tokens(usage),
            completion_tokens=usage.output_tokens if usage else 0,
            cost_usd=call_cost(str(model), usage))

    def classify(self, exc: BaseException) -> tuple[str, bool]:
        """What a failure Inspect gave up on was; never transient (Inspect retried it)."""
        status = status_code(exc)
        if status is not None:
            if status == 400 and is_context_window_message(str(exc)):
                return "context_window", False
            return status_kind(status)[0], False
        name = type(exc).__name__
        if isinstance(exc, TimeoutError) or "Timeout" in name:
            return "timeout", False
        if "Connect" in name:  # (Connection…, Connect…) no answer: what LiteLLM retries
            return "transient", False
        return "other", False

    def _error(self, exc: BaseException, latency_s: float, spent: dict[str, Any]) -> Any:
        exc = last_failure(exc)
        if _is_limit(exc):  # not a model failure: Inspect ends the sample at its limit
            raise InspectLimitReached(exc) from exc
        error = super()._error(exc, latency_s, spent)
        cause = exc.__cause__
        if cause is not None and str(cause) and str(cause) not in error.message:
            # the provider's words often lie one level down ("Connection error." ← refused)
            error.message = redact(f"{error.message} ({type(cause).__name__}: {cause})",
                                   self.settings.secrets())
        return error


def last_failure(exc: BaseException) -> BaseException:
    """The exception behind Inspect's retries: the last attempt's, where they ran out (a
    tenacity `RetryError` says nothing of the provider's words)."""
    while type(exc).__name__ == "RetryError" and getattr(exc, "last_attempt", None):
        inner = exc.last_attempt.exception()
        if inner is None:
            break
        exc = inner
    return exc


class InspectLimitReached(EpisodeHalt):
    """An Inspect usage limit (tokens, cost, time, …) stopped the episode; `limit` is
    Inspect's `LimitExceededError`, which the solver hands back to Inspect."""

    def __init__(self, limit: BaseException) -> None:
        super().__init__(str(limit))
        self.limit = limit


class InspectOutputError(Exception):
    """Inspect's model returned an output carrying an error instead of an answer."""


def _is_limit(exc: BaseException) -> bool:
    from inspect_ai.util import LimitExceededError

    return isinstance(exc, LimitExceededError)


#: Our call parameters that are fields of Inspect's `GenerateConfig` under the same name,
#: which every Inspect provider sends (in its API's terms). Any other goes in `extra_body`,
#: sent as a field of the request's body as the other transports send `--extra`: `top_k`
#: among them, which Inspect's OpenAI providers would drop and local servers take.
_CONFIG_FIELDS = frozenset({
    "temperature", "max_tokens", "seed", "top_p", "frequency_penalty", "presence_penalty",
    "logit_bias", "logprobs", "top_logprobs", "extra_headers", "reasoning_effort"})
#: OpenAI's names of `GenerateConfig` fields named otherwise.
_CONFIG_ALIASES = {"stop": "stop_seqs", "max_completion_tokens": "max_tokens"}


def generate_config(params: dict[str, Any]) -> dict[str, Any]:
    """Our call parameters (`RemoteClient.call_params`: the sampling settings, `--extra`, the
    grammar) as Inspect `GenerateConfig` fields: every one is sent, as by `cocobench run`."""
    config: dict[str, Any] = {}
    extra_body = dict(params.get("extra_body") or {})
    for name, value in params.items():
        field = _CONFIG_ALIASES.get(name, name)
        if field in _CONFIG_FIELDS:
            config[field] = [value] if field == "stop_seqs" and isinstance(value, str) \
                else value
        elif name != "extra_body":
            extra_body[name] = value
    if extra_body:
        config["extra_body"] = extra_body
    return config


def served_from_cache(output: Any, since: int) -> bool:
    """Whether Inspect answered with `output` from its response cache: the latest model event
    of the sample's transcript that carries it (a copy of it) says so (``cache="read"``).
    Only the events logged from the index `since` on are read (the transcript's event count
    before the call): a sample's calls then read its transcript once in all, not once each
    (`Transcript.events` may even re-read its history from the start for every index)."""
    from inspect_ai.log import transcript

    for event in reversed(transcript().history.events_from(since)):
        if getattr(event, "event", None) == "model" and (event.output is output
                                                         or event.output == output):
            return event.cache == "read"
    return False


def prompt_tokens(usage: Any) -> int:
    """The prompt's tokens as the provider counted them, a cached prefix included (Inspect
    counts the tokens read from or written to a provider's prompt cache apart from
    `input_tokens`; LiteLLM's and our counts include them)."""
    if usage is None:
        return 0
    return (usage.input_tokens + (usage.input_tokens_cache_read or 0)
            + (usage.input_tokens_cache_write or 0))


def call_cost(model: str, usage: Any) -> float:
    """The call's cost in USD: Inspect's own where it priced the call (its model cost
    config), else priced from LiteLLM's cost map as `cocobench run` prices it, by the model's
    name (``openai/gpt-4o``) or its last part (``openai-api/SERVICE/gpt-4o``); 0 for a model
    neither prices. Without this, every Inspect decision cost 0."""
    if usage is None:
        return 0.0
    if usage.total_cost is not None:
        return float(usage.total_cost)
    for name in (model, model.rsplit("/", 1)[-1]):
        price_in, price_out = token_prices(name)
        if price_in or price_out:
            return prompt_tokens(usage) * price_in + usage.output_tokens * price_out
    return 0.0


def chat_messages(messages: list[dict[str, Any]]) -> list[Any]:
    """Our OpenAI-style messages (`messages.build_messages`) as Inspect chat messages: text
    parts as `ContentText`, image frames as `ContentImage`."""
    from inspect_ai.model import ChatMessageUser, ContentImage, ContentText

    out = []
    for message in messages:
        content = message["content"]
        if isinstance(content, list):
            content = [ContentImage(image=part["image_url"]["url"])
                       if part["type"] == "image_url" else ContentText(text=part["text"])
                       for part in content]
        out.append(ChatMessageUser(content=content))
    return out

