"""A model call made around `decide` and `ask` (a client of the planner's context used
directly) is a recorded decision too, recorded by the client: the context hands out its
clients wrapped (`recording_clients`), and `decide`, `ask` and the leader, which record their
calls themselves, call the client inside (`unrecorded`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from cocobench_agents.models.protocol import (
    EpisodeHalt,
    ModelClient,
    ModelError,
    ModelReply,
    ModelRequest,
)
from cocobench_agents.models.retry import AttemptingClient
from cocobench_agents.tools import EpisodeTools, prompt_hash, prompt_text, reply_fields

#: The statuses of a call made with a client directly: answered, or failed.
DIRECT, DIRECT_ERROR = "direct", "direct_error"


class RecordingClient:
    """A client as a planner's context hands it out: each call made with it directly is
    recorded in the episode's decisions (status ``direct``, or ``direct_error`` with the
    error), so that usage, cost and the viewer count it. Everything else is the client's."""

    def __init__(self, client: ModelClient, tools: EpisodeTools) -> None:
        self.client, self.tools = client, tools
        self.name = client.name

    def __getattr__(self, name: str) -> Any:
        if name == "client":  # not set yet (a copy being made): no recursion
            raise AttributeError(name)
        return getattr(self.client, name)

    async def complete(self, request: ModelRequest) -> ModelReply:
        """The client's answer to `request`, recorded."""
        return await self._recorded(request, lambda: self.client.complete(request))

    async def _recorded(self, request: ModelRequest, call: Any) -> ModelReply:
        prompt = self.tools.keep(prompt_text(request.prompt))
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
