"""Configuration errors found before any episode starts."""

from __future__ import annotations

from .secrets import redact


class ModelConfigError(ValueError):
    """A model spec that cannot be used as configured: unknown model, missing API key,
    missing or unreadable file of a built-in client. The message is one line naming the
    model and what to do about it."""

    def __init__(self, model: str, message: str) -> None:
        self.model = redact(model)
        self.message = redact(message)
        super().__init__(f"{self.model}: {self.message}")
