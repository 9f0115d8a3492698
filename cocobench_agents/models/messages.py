"""Chat messages for a `ModelRequest`, and the reply-size cap."""

from __future__ import annotations

import base64
from typing import Any

from .protocol import ModelRequest

#: Appended to a reply cut at `ModelSettings.max_reply_chars`; followed by the dropped count.
TRUNCATION_MARKER = "\n[cocobench: reply truncated, "


def image_data_url(png: bytes) -> str:
    """A ``data:image/png;base64,…`` URL for one PNG frame."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def build_messages(request: ModelRequest) -> list[dict[str, Any]]:
    """One user message: the prompt alone (text mode), or the prompt then one ``image_url``
    part per frame (image mode), as the reference sends them."""
    if not request.images:
        return [{"role": "user", "content": request.prompt}]
    content: list[dict[str, Any]] = [{"type": "text", "text": request.prompt}]
    content.extend(
        {"type": "image_url", "image_url": {"url": image_data_url(png)}} for png in request.images
    )
    return [{"role": "user", "content": content}]


def cap_reply(text: str, max_chars: int) -> tuple[str, bool]:
    """`text` cut to `max_chars` characters with a marker saying how much was dropped,
    and whether it was cut."""
    if len(text) <= max_chars:
        return text, False
    return f"{text[:max_chars]}{TRUNCATION_MARKER}{len(text) - max_chars} chars dropped]", True


def is_truncated(text: str) -> bool:
    """Whether a reply text was cut by `cap_reply`."""
    return TRUNCATION_MARKER in text
