"""What a failed model call was, whichever client made it: the `ModelError` kind it becomes
and whether a retry can help."""

from __future__ import annotations


class EmptyCompletion(Exception):
    """The provider answered, but with no text (retried like a transient error)."""


class MalformedCompletion(Exception):
    """The provider answered 200 with a body that is not a chat completion (retried)."""


def status_kind(status: int) -> tuple[str, bool]:
    """``(kind, transient)`` for an HTTP error status.

    Transient (retried): 5xx, 429, and the 408/409 the reference also retries; every other
    client error fails fast.
    """
    if status >= 500 or status in (408, 409):
        return "transient", True
    if status == 429:
        return "rate_limit", True
    if status in (401, 403):
        return "auth", False
    if status == 404:
        return "not_found", False
    if 400 <= status < 500:
        return "bad_request", False
    return "other", False


def is_context_window_message(text: str) -> bool:
    """Whether a 400's message says the prompt was too long (providers word it differently,
    and most give no distinct code)."""
    text = text.lower()
    return any(phrase in text for phrase in (
        "context length", "context_length", "context window", "maximum context",
        "too many tokens", "exceeds the available context", "prompt is too long"))


def is_unsupported_input_message(text: str) -> bool:
    """Whether an error's message says the model cannot take the request's input (an image
    sent to a text-only model). Servers send it with any status, llama.cpp's as a 500 that
    would otherwise be retried: no retry or later call can succeed."""
    text = text.lower()
    return any(phrase in text for phrase in (
        "image input is not supported", "does not support image", "not support images",
        "images are not supported", "image_url is only supported", "vision is not supported",
        "multimodal is not supported", "does not support multimodal"))


def status_code(exc: BaseException) -> int | None:
    """The HTTP status an exception carries, if any."""
    status = getattr(exc, "status_code", None)
    try:
        return None if status is None else int(status)
    except (TypeError, ValueError):
        return None


def retry_after_s(exc: BaseException) -> float | None:
    """The server's ``Retry-After`` in seconds (numeric form only), if the error carries one."""
    # LiteLLM keeps the provider's real headers apart; its `response` is often a stand-in.
    candidates = (
        getattr(exc, "headers", None),
        getattr(exc, "litellm_response_headers", None),
        getattr(getattr(exc, "response", None), "headers", None),
    )
    for headers in candidates:
        try:
            value = headers.get("retry-after") if headers is not None else None
            if value is not None:
                return max(0.0, float(value))
        except (TypeError, ValueError, AttributeError):
            continue
    return None
