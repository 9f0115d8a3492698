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
import sys
from typing import Any

from .errors import ModelConfigError
from .failures import is_context_window_message, status_code, status_kind
from .protocol import EpisodeHalt, ModelReply, ModelRequest
from .remote import Completion, RemoteClient

#: The deciding agent of the call in flight (a contextvar: `send` does not get the request).
_AGENT: contextvars.ContextVar[str | None] = contextvars.ContextVar("cocobench_agent",
                                                                   default=None)
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
    from inspect_ai.model._model import model_roles

    role = model_roles().get(agent)
    if isinstance(role, list):
        role = role[0] if role else None
    return role


class InspectClient(RemoteClient):
    """A `ModelClient` that asks Inspect's model of the running sample."""

    transport = "inspect"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.cache = None  # Inspect's own cache applies, not ours

    async def attempt(self, request: ModelRequest, number: int) -> ModelReply:
        token = _AGENT.set(request.agent)
        try:
            return await super().attempt(request, number)
        finally:
            _AGENT.reset(token)

    async def send(self, messages: list[dict[str, Any]], params: dict[str, Any],
                   timeout_s: float) -> Completion:
        from inspect_ai.model import GenerateConfig

        model = inspect_model(_AGENT.get())
        extra_body = params.get("extra_body")
        config = GenerateConfig(
            temperature=params.get("temperature"), max_tokens=params.get("max_tokens"),
            seed=params.get("seed"), extra_body=extra_body)
        output = await model.generate(chat_messages(messages), config=config)
        if output.error:  # a refusal or content filter the provider reported as such
            raise InspectOutputError(output.error)
        usage = output.usage
        return Completion(
            text=output.completion or "",
            prompt_tokens=usage.input_tokens if usage else 0,
            completion_tokens=usage.output_tokens if usage else 0,
            cost_usd=(usage.total_cost or 0.0) if usage else 0.0)

    def classify(self, exc: BaseException) -> tuple[str, bool]:
        """What a failure Inspect gave up on was; never transient (Inspect retried it)."""
        status = status_code(exc)
        if status is not None:
            if status == 400 and is_context_window_message(str(exc)):
                return "context_window", False
            return status_kind(status)[0], False
        if isinstance(exc, TimeoutError):
            return "timeout", False
        return "other", False

    def _error(self, exc: BaseException, latency_s: float, spent: dict[str, Any]) -> Any:
        if _is_limit(exc):  # not a model failure: Inspect ends the sample at its limit
            raise InspectLimitReached(exc) from exc
        return super()._error(exc, latency_s, spent)


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

