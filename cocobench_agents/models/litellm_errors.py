"""Which LiteLLM failures are worth retrying, and which `ModelError` kind each one becomes."""

from __future__ import annotations

import asyncio
from types import ModuleType

from .failures import status_code, status_kind


def classify(litellm: ModuleType, exc: BaseException) -> tuple[str, bool]:
    """``(kind, transient)`` for an exception raised by ``litellm.acompletion``.

    Transient (retried): rate limits, timeouts, connection errors and 5xx.
    The reference also retries 408/409; LiteLLM maps 408 to `Timeout`, and 409 and other 5xx
    arrive as a plain `APIError` with that status. Every other client error fails fast.
    """
    # Order matters: ContextWindowExceededError and ContentPolicyViolationError are
    # BadRequestErrors, and Timeout derives from openai's APIConnectionError.
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
    return ("other", False) if status is None else status_kind(status)


def _missing_credentials(exc: BaseException) -> bool:
    # The OpenAI SDK refuses to send a request without a key; LiteLLM reports that as an
    # InternalServerError, which must not be retried.
    text = str(exc)
    return "Missing credentials" in text or "api_key client option must be set" in text
