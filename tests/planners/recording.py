"""Test helpers: a client that records every request and answers like a scripted model."""

from __future__ import annotations

from dataclasses import dataclass, field

from cocobench_agents.models import GreedyClient, ModelReply, ModelRequest


@dataclass
class RecordingClient:
    """Greedy answers (with a REASON and a MSG line); every request is kept."""

    name: str = "recording"
    accepts_images: bool = True
    requests: list[ModelRequest] = field(default_factory=list)

    async def complete(self, request: ModelRequest) -> ModelReply:
        self.requests.append(request)
        greedy = await GreedyClient().complete(request)
        return ModelReply(f"REASON: make progress\n{greedy.text}\nMSG: on it")


class RecordingPool:
    """Hands out one shared `RecordingClient`, so the requests of a whole episode are in order."""

    def __init__(self) -> None:
        self.client_ = RecordingClient()

    def client(self, spec: str, *, episode: str, agent: str | None) -> RecordingClient:
        return self.client_

    def release(self, episode: str) -> None:
        pass
