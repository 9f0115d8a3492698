"""Chat messages for a `ModelRequest`, and the reply-size cap."""

from __future__ import annotations

import base64
from typing import Any

from .protocol import ModelRequest


def image_data_url(png: bytes) -> str:
    """A ``data:image/png;base64,…`` URL for one PNG frame."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def build_messages(request: ModelRequest) -> list[dict[str, Any]]:
    """One user message: the prompt alone (text mode), or the prompt then one ``image_url``
    part per frame (image mode), as the reference sends them. A prompt of content parts is
    sent as its parts, the frames after them."""
    if not request.images:
        return [{"role": "user", "content": request.prompt}]
    content: list[dict[str, Any]] = (
        list(request.prompt) if isinstance(request.prompt, list)
        else [{"type": "text", "text": request.prompt}])
    content.extend(
        {"type": "image_url", "image_url": {"url": image_data_url(png)}} for png in request.images
    )
    return [{"role": "user", "content": content}]


def cap_reply(text: str, max_chars: int) -> tuple[str, int]:
    """The first `max_chars` characters of `text`, and how many were dropped.

    Nothing is added to the text: a note in it would be parsed as if the model had written it
    (the bare-integer fallback once read the dropped count as an action id). The count goes
    into `ModelReply.truncated_chars` instead."""
    return text[:max_chars], max(0, len(text) - max_chars)
