"""One model decision: prompt → model → parsed reply → decision record; and a strategy's own
model call (`ask`), recorded as a decision.

Never raises: a failing model becomes a `backend_error` decision, so one agent's trouble
cannot fail a decentralized round (LangGraph fails a whole step when one branch raises). The
exceptions that pass are `EpisodeHalt`s, a human seat's desk pausing the episode
(`HumanTurn`) or a usage limit of the harness the model runs in, and the infrastructure's
own (`node_errors.is_infrastructure_failure`): a human seat's answer log that cannot be
read or written stops the run, as any run folder that cannot be used.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

from benchmark_adapter.menu import MenuEntry
from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.model_calls import unrecorded
from cocobench_agents.graphs.node_errors import is_infrastructure_failure
from cocobench_agents.models.protocol import (
    EpisodeHalt,
    MenuOption,
    ModelClient,
    ModelError,
    ModelReply,
    ModelRequest,
)
from cocobench_agents.models.retry import RetryPolicy
from cocobench_agents.prompts import ParsedReply, parse_message, parse_reply
from cocobench_agents.tools import EpisodeTools, model_decision, stop_decision


def accepts_images(client: object) -> bool:
    """Whether a client reads images (built-in clients do not; rendering them is wasted)."""
    return bool(getattr(client, "accepts_images", True))


def no_actions_decision(tools: EpisodeTools, agent: str | None, *, policy: str,
                        model: str) -> dict[str, Any]:
    """The decision on an empty menu, where `decide` asks no model: a ``no_actions`` stop."""
    return stop_decision(policy=policy, model=model, agent=agent,
                         step_index=tools.step_index, status="no_actions")


async def decide(ctx: PlannerContext, agent: str | None, *, policy: str,
                 history: Sequence[str], messages: Sequence[Mapping[str, str]] = (),
                 broadcast: bool = False, retry: RetryPolicy | None = None) -> dict[str, Any]:
    """Ask `agent`'s model (the team's model when None) for its next action, retrying
    transient failures under `retry` (default: the context's `retry_policy`)."""
    tools = ctx.tools
    client = unrecorded(ctx.client_for(agent))  # recorded here, not by the client
    prompt, images, menu = tools.prompt(agent, history, messages, broadcast,
                                        with_images=accepts_images(client))
    if not menu:
        return no_actions_decision(tools, agent, policy=policy, model=client.name)
    request = ModelRequest(prompt=prompt, images=images, menu=tools.menu_options(agent),
                           agent=agent, sample_index=ctx.sample_index,
                           step_index=tools.step_index)
    reply = await reply_or_error(client, request, retry or ctx.retry_policy)
    if isinstance(reply, ModelError):  # idles this agent only
        return model_decision(policy=policy, model=client.name, agent=agent,
                              step_index=tools.step_index, prompt=prompt, parsed=None,
                              call=None, error=reply)
    return reply_decision(tools, agent, menu, prompt, reply, policy=policy,
                          model=client.name, broadcast=broadcast)


async def reply_or_error(client: ModelClient, request: ModelRequest, retry: RetryPolicy
                         ) -> ModelReply | ModelError:
    """`client`'s reply to `request` under `retry`, or the error it failed with (any
    exception of a client becomes a `ModelError`). An `EpisodeHalt` passes: not a failure
    but a person's turn or a harness's usage limit; so does the infrastructure's own
    failure (the run folder's, from a human seat's answer log): not the model's."""
    started = time.perf_counter()
    try:
        return await retry.complete(client, request)
    except EpisodeHalt:
        raise
    except Exception as exc:  # a failing client is the call's outcome
        if is_infrastructure_failure(exc):
            raise
        return exc if isinstance(exc, ModelError) else ModelError(
            "other", repr(exc), latency_s=time.perf_counter() - started)


def reply_decision(tools: EpisodeTools, agent: str | None, menu: Sequence[MenuEntry],
                   prompt: str, reply: ModelReply, *, policy: str, model: str,
                   broadcast: bool) -> dict[str, Any]:
    """The decision record of `reply`, a model's answer to `prompt` for `agent` with `menu`:
    its action parsed against the menu, and under `broadcast` its message."""
    parsed = parse_reply(reply.text, [e.action_id for e in menu])
    call = (next((e.call for e in menu if e.action_id == parsed.action_id), None)
            if parsed.status == "action" else None)
    return model_decision(policy=policy, model=model, agent=agent,
                          step_index=tools.step_index, prompt=prompt, parsed=parsed,
                          call=call, reply=reply,
                          message=parse_message(reply.text) if broadcast else "")


#: The status of an `ask` without a menu: the reply is the answer, as written.
REPLY = "reply"


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
                                      with_images=accepts_images(client))
    request = ModelRequest(prompt=prompt, images=images, menu=options, agent=agent,
                           sample_index=ctx.sample_index, step_index=tools.step_index)
    common = {"policy": policy or template, "model": client.name, "agent": agent,
              "step_index": tools.step_index, "prompt": prompt, "call": None}
    reply = await reply_or_error(client, request, retry or ctx.retry_policy)
    if isinstance(reply, ModelError):
        record, answer = model_decision(parsed=None, error=reply, **common), None
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
