"""The `ModelClient` protocol: how planners talk to any model, built-in or remote."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

#: A request's prompt: its text, or chat content parts a strategy gives to be sent as they
#: are (``[{"type": "text", "text": …}, {"type": "image_url", …}]``, `chat_schema` checks
#: them); the frames of `ModelRequest.images` go after either.
Prompt = str | list[dict[str, Any]]


@dataclass(frozen=True)
class MenuOption:
    """One menu entry as a model client may see it (built-in clients choose from these;
    constrained decoding builds its grammar from their ids)."""

    action_id: int
    skill: str
    call: str


#: The team's seat: the one name of the model that decides for the whole team (a centralized
#: planner's, a leader's), whose requests carry no `agent`. A planner context's clients, a
#: `scripted:` file and a person's desk name it so.
TEAM_SEAT = "team"


@dataclass(frozen=True)
class ModelRequest:
    """One planner decision to make."""

    prompt: Prompt
    images: tuple[bytes, ...] = ()  # PNG frames, sent in image mode only
    menu: tuple[MenuOption, ...] = ()  # the ids the prompt offers
    agent: str | None = None  # the deciding agent (None for a centralized planner)
    sample_index: int = 0  # epoch / repeated sample; part of the cache key
    step_index: int = 0  # steps landed so far (shown to a person; never sent to a model)


def prompt_text(prompt: Prompt) -> str:
    """A request's prompt as the text that is kept and hashed: the text itself, or content
    parts as canonical JSON, so that they are recorded like any other prompt and the
    request's check or server judges them."""
    if isinstance(prompt, str):
        return prompt
    return json.dumps(prompt, sort_keys=True, ensure_ascii=False, default=repr)


def prompt_words(prompt: Prompt) -> str:
    """What a prompt says: its text, or the text of its text parts, one a line (what asks
    for a ``MSG:`` line, say)."""
    if isinstance(prompt, str):
        return prompt
    return "\n".join(part["text"] for part in prompt if isinstance(part, dict)
                     and part.get("type") == "text" and isinstance(part.get("text"), str))


@dataclass(frozen=True)
class ModelReply:
    """A model's answer and what it cost when the model gave it. A reused reply (`cached`:
    from the response cache; `replayed`: from an earlier run's trajectory) keeps those
    figures, but costs nothing now: decision records bill it 0 and keep them as "saved"."""

    text: str
    prompt_tokens: int = 0
    completion_tokens: int = 0
    cost_usd: float = 0.0
    latency_s: float = 0.0
    retries: int = 0
    cached: bool = False
    replayed: bool = False
    # Characters cut off the end of `text` by `ModelSettings.max_reply_chars` (0: none). Kept
    # apart from `text` so that parsing only ever reads what the model wrote.
    truncated_chars: int = 0

    @property
    def reused(self) -> bool:
        """Whether no model was called for this reply now."""
        return self.cached or self.replayed


@dataclass
class ModelError(Exception):
    """The model gave no usable answer (after retries: a `backend_error` decision).

    `kind` is one of: transient (retries exhausted), timeout, rate_limit, context_window,
    bad_request, unsupported_input (an image to a text-only model), auth, not_found, empty,
    other.
    """

    kind: str
    message: str
    retries: int = 0
    latency_s: float = 0.0
    extra: dict = field(default_factory=dict)
    transient: bool = False  # another attempt may succeed (a `RetryPolicy` retries it)
    retry_after_s: float | None = None  # the server's Retry-After, when it sent one

    def __str__(self) -> str:
        return f"{self.kind}: {self.message}"


class EpisodeHalt(Exception):
    """Raised by a client to end the episode where it stands without a model failure: a
    human seat's turn (`HumanTurn`), a usage limit of the harness the model runs in. A
    planner's decision lets it pass; the runner stops the episode with it."""


@runtime_checkable
class ModelClient(Protocol):
    """Anything that can answer a `ModelRequest`."""

    name: str  # the model string recorded in decisions and results

    async def complete(self, request: ModelRequest) -> ModelReply:
        """Answer one request; raise `ModelError` when no usable answer can be had."""
        ...
