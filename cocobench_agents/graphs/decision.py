"""One model decision: prompt → model → parsed reply → decision record.

Never raises: a failing model becomes a `backend_error` decision, so one agent's trouble
cannot fail a decentralized round (LangGraph fails a whole step when one branch raises). The
exceptions that pass are `EpisodeHalt`s: a human seat's desk pausing the episode
(`HumanTurn`), a usage limit of the harness the model runs in.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

from benchmark_adapter.menu import MenuEntry
from cocobench_agents.graphs.context import PlannerContext
from cocobench_agents.graphs.model_calls import unrecorded
from cocobench_agents.models.protocol import EpisodeHalt, ModelError, ModelReply, ModelRequest
from cocobench_agents.models.retry import RetryPolicy
from cocobench_agents.prompts import parse_message, parse_reply
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
    started = time.perf_counter()
    try:
        reply = await (retry or ctx.retry_policy).complete(client, request)
    except EpisodeHalt:  # not a failure: a person's turn, a harness's usage limit
        raise
    except Exception as exc:  # noqa: BLE001 - any client failure idles this agent only
        error = exc if isinstance(exc, ModelError) else ModelError(
            "other", repr(exc), latency_s=time.perf_counter() - started)
        return model_decision(policy=policy, model=client.name, agent=agent,
                              step_index=tools.step_index, prompt=prompt, parsed=None,
                              call=None, error=error)
    return reply_decision(tools, agent, menu, prompt, reply, policy=policy,
                          model=client.name, broadcast=broadcast)


def reply_decision(tools: EpisodeTools, agent: str | None, menu: Sequence[MenuEntry],
                   prompt: str, reply: ModelReply, *, policy: str, model: str,
                   broadcast: bool) -> dict[str, Any]:
    """The decision record of `reply`, a model's answer to `prompt` for `agent` with `menu`:
    its action parsed against the menu, and under `broadcast` its message. The training
    environment (`cocobench_agents.envs`) turns a seat's action into its decision here."""
    parsed = parse_reply(reply.text, [e.action_id for e in menu])
    call = (next((e.call for e in menu if e.action_id == parsed.action_id), None)
            if parsed.status == "action" else None)
    return model_decision(policy=policy, model=model, agent=agent,
                          step_index=tools.step_index, prompt=prompt, parsed=parsed,
                          call=call, reply=reply,
                          message=parse_message(reply.text) if broadcast else "")
