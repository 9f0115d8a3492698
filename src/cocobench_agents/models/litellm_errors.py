"""Which LiteLLM failures are worth retrying, and which `ModelError` kind each one becomes."""

from __future__ import annotations

import asyncio
from types import ModuleType


class EmptyCompletion(Exception):
    """The provider answered, but with no text (retried like a transient error)."""


def classify(litellm: ModuleType, exc: BaseException) -> tuple[str, bool]:
    """``(kind, transient)`` for an exception raised by ``litellm.acompletion``.

    Transient (retried): rate limits, timeouts, connection errors, 5xx, and empty completions.
    The reference also retries 408/409; LiteLLM maps 408 to `Timeout`, and 409 and other 5xx
    arrive as a plain `APIError` with that status. Every other client error fails fast.
    """
    # Order matters: ContextWindowExceededError and ContentPolicyViolationError are
    # BadRequestErrors, and Timeout derives from openai's APIConnectionError.
    if isinstance(exc, EmptyCompletion):
        return "empty", True
    if isinstance(exc, litellm.ContextWindowExceededError):
        return "context_window", False
    if isinstance(exc, litellm.ContentPolicyViolationError):
        return "bad_request", False
    if _missing_credentials(exc):
        return "auth", False
    if isinstance(exc, (litellm.Timeout, asyncio.TimeoutError, TimeoutError)):
        return "timeout", True
    if isinstance(exc, litellm.RateLimitError):
        return "rate_limit", True
    if isinstance(exc, (litellm.AuthenticationError, litellm.PermissionDeniedError)):
        return "auth", False
    if isinstance(exc, litellm.NotFoundError):
        return "not_found", False
    if isinstance(exc, (litellm.BadRequestError, litellm.UnprocessableEntityError)):
        # LiteLLM maps by message as well as status: a 401 whose body says
        # "invalid_request_error" arrives as a BadRequestError.
        status = status_code(exc)
        if status in (401, 403):
            return "auth", False
        if status == 404:
            return "not_found", False
        return "bad_request", False
    if isinstance(
        exc,
        (
            litellm.InternalServerError,
            litellm.ServiceUnavailableError,
            litellm.BadGatewayError,
            litellm.APIConnectionError,
        ),
    ):
        return "transient", True
    status = status_code(exc)
    if status is None:
        return "other", False
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


def _missing_credentials(exc: BaseException) -> bool:
    # The OpenAI SDK refuses to send a request without a key; LiteLLM reports that as an
    # InternalServerError, which must not be retried.
    text = str(exc)
    return "Missing credentials" in text or "api_key client option must be set" in text


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
