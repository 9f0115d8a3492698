"""Every model call a strategy makes is a recorded decision.

`ask` is a strategy's own call: one of its templates (`PlannerSpec.templates`, part of the
prompt suite) rendered for a seat, sent through the run's retry policy and recorded as it
returns, like a decision: prompt kept, reply, usage, cost. A call made around `decide` and
`ask` (a client of the context used directly) is recorded too, by the client: the context
hands out its clients wrapped (`recording_clients`), and `decide`, `ask` and the leader, which
record their calls themselves, call the client inside (`unrecorded`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from cocobench_agents.models.protocol import (
    EpisodeHalt,
    MenuOption,
    ModelClient,
    ModelError,
    ModelReply,
    ModelRequest,
)
from cocobench_agents.models.retry import AttemptingClient, RetryPolicy
from cocobench_agents.prompts import ParsedReply, parse_reply
from cocobench_agents.tools import EpisodeTools, model_decision, prompt_hash, reply_fields

if TYPE_CHECKING:
    from cocobench_agents.graphs.context import PlannerContext

#: The status of an `ask` without a menu: the reply is the answer, as written.
REPLY = "reply"
#: The statuses of a call made with a client directly: answered, or failed.
DIRECT, DIRECT_ERROR = "direct", "direct_error"


async def ask(ctx: PlannerContext, agent: str | None, template: str,
              fields: Mapping[str, object] | None = None, *,
              menu: Sequence[str | MenuOption] = (), history: Sequence[str] = (),
              policy: str | None = None, retry: RetryPolicy | None = None) -> dict[str, Any]:
    """Ask `agent`'s model (the team's model when None) the planner's own `template`, filled
    with `fields` over the seat's view; recorded now, and returned: the decision record, whose
    ``answer`` is the chosen `menu` entry (the reply's ``ACTION: <n>``, n from 1), or with no
    menu the reply's text; None when the model gave none (``status`` says why).

    `menu` entries are texts (numbered from 1) or `MenuOption`s (their own ids); the template's
    ``{menu}`` lists them, and the built-in models (greedy, random, scripted) choose from them.
    `history` fills ``{history_section}``. Transient failures are retried under `retry`
    (default: the context's `retry_policy`). Never raises for a model's failure (a
    ``backend_error`` record); a template or field the suite lacks is the strategy's error
    (a `ValueError` naming it)."""
    tools = ctx.tools
    client = unrecorded(ctx.client_for(agent))
    options = menu_options(menu)
    prompt, images = tools.ask_prompt(agent, template, fields or {}, options, history,
                                      with_images=bool(getattr(client, "accepts_images", True)))
    request = ModelRequest(prompt=prompt, images=images, menu=options, agent=agent,
                           sample_index=ctx.sample_index, step_index=tools.step_index)
    common = {"policy": policy or template, "model": client.name, "agent": agent,
              "step_index": tools.step_index, "prompt": prompt, "call": None}
    started = time.perf_counter()
    try:
        reply = await (retry or ctx.retry_policy).complete(client, request)
    except EpisodeHalt:  # not a failure: a person's turn, a harness's usage limit
        raise
    except Exception as exc:  # noqa: BLE001 - a failing model is this call's outcome
        error = exc if isinstance(exc, ModelError) else ModelError(
            "other", repr(exc), latency_s=time.perf_counter() - started)
        record, answer = model_decision(parsed=None, error=error, **common), None
    else:
        parsed = (parse_reply(reply.text, [o.action_id for o in options]) if options
                  else ParsedReply(REPLY))
        record = model_decision(parsed=parsed, reply=reply, **common)
        answer = _answer(parsed, options, reply)
    record.update(ask=template, answer=answer, terminal_reason=None)
    return tools.record(record)


def menu_options(menu: Sequence[str | MenuOption]) -> tuple[MenuOption, ...]:
    """An ask's menu as model clients see it: texts numbered from 1, options as given."""
    return tuple(entry if isinstance(entry, MenuOption) else
                 MenuOption(index, "choice", str(entry))
                 for index, entry in enumerate(menu, start=1))


def _answer(parsed: ParsedReply, options: Sequence[MenuOption], reply: ModelReply
            ) -> str | None:
    if not options:
        return reply.text
    if parsed.status != "action":
        return None
    return next(o.call for o in options if o.action_id == parsed.action_id)


# -- calls made around decide and ask --------------------------------------------------------

class RecordingClient:
    """A client as a planner's context hands it out: each call made with it directly is
    recorded in the episode's decisions (status ``direct``, or ``direct_error`` with the
    error), so that usage, cost and the viewer count it. Everything else is the client's."""

    def __init__(self, client: ModelClient, tools: EpisodeTools) -> None:
        self.client, self.tools = client, tools
        self.name = client.name

    def __getattr__(self, name: str) -> Any:
        return getattr(self.client, name)

    async def complete(self, request: ModelRequest) -> ModelReply:
        """The client's answer to `request`, recorded."""
        return await self._recorded(request, lambda: self.client.complete(request))

    async def _recorded(self, request: ModelRequest, call: Any) -> ModelReply:
        prompt = self.tools.keep(request.prompt)
        record = {"policy": DIRECT, "model": self.name, "agent": request.agent,
                  "step_index": self.tools.step_index, "status": DIRECT,
                  "terminal_reason": None, "parsed_call": None,
                  "prompt_hash": prompt_hash(prompt)}
        started = time.perf_counter()
        try:
            reply = await call()
        except EpisodeHalt:
            raise
        except Exception as exc:
            spent = exc.extra if isinstance(exc, ModelError) else {}
            self.tools.record({
                **record, "status": DIRECT_ERROR, "error": str(exc),
                "error_kind": exc.kind if isinstance(exc, ModelError) else "other",
                "latency_s": round(time.perf_counter() - started, 4),
                **{k: spent[k] for k in ("prompt_tokens", "completion_tokens", "cost_usd")
                   if k in spent}})
            raise
        self.tools.record({**record, **reply_fields(reply)})
        return reply


class RecordingAttemptingClient(RecordingClient):
    """A `RecordingClient` of a client that answers one attempt at a time (a remote model):
    a retry policy used directly makes its attempts here, each recorded."""

    async def attempt(self, request: ModelRequest, number: int) -> ModelReply:
        """Attempt `number` at `request`, recorded."""
        return await self._recorded(request, lambda: self.client.attempt(request, number))


def recording_clients(clients: Mapping[str, ModelClient], tools: EpisodeTools
                      ) -> dict[str, ModelClient]:
    """`clients`, each wrapped to record the calls made with it directly."""
    return {seat: _recording(client, tools) for seat, client in clients.items()}


def _recording(client: ModelClient, tools: EpisodeTools) -> ModelClient:
    if isinstance(client, RecordingClient):
        return client
    kind = RecordingAttemptingClient if isinstance(client, AttemptingClient) else RecordingClient
    return kind(client, tools)


def unrecorded(client: ModelClient) -> ModelClient:
    """The client inside a `RecordingClient`: for a caller that records its call itself
    (`decide`, `ask`, the leader)."""
    return client.client if isinstance(client, RecordingClient) else client
