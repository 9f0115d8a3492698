"""`ModelSettings`: how remote models are called (endpoint, key, timeouts, retries, sampling)."""

from __future__ import annotations

import base64
import ipaddress
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit, urlunsplit

from .secrets import named_secrets, redact_named, redact_obj, redact_url, url_credentials

#: `temperature` value meaning "as the reference": 0 for OpenAI model names starting with
#: gpt/o1/o3/o4, not sent otherwise.
TEMPERATURE_AUTO = "auto"
_REFERENCE_T0_PREFIXES = ("gpt", "o1", "o3", "o4")
#: The key sent to a local server when no `api_key_env` is given (OpenAI-style clients
#: refuse to send a request without one; local servers rarely check it).
LOCAL_PLACEHOLDER_KEY = "no-key-required"
#: How remote models are called: through LiteLLM (the default, any provider), or ``http``, a
#: lean OpenAI-compatible client for high-concurrency runs (see `openai_http`).
TRANSPORTS = ("litellm", "http")


def is_local_url(url: str | None) -> bool:
    """Whether `url` points at this machine (loopback or unspecified address, localhost)."""
    if not url:
        return False
    host = urlsplit(url if "//" in url else f"//{url}").hostname or ""
    if host == "localhost":
        return True
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        return False
    return address.is_loopback or address.is_unspecified


@dataclass(frozen=True)
class ModelSettings:
    """Settings shared by every remote model of a run.

    * `api_base`: endpoint URL (e.g. ``http://127.0.0.1:8080/v1`` for a local llama.cpp or
      vLLM server); None = the provider's default.
    * `api_key_env`: the NAME of the environment variable holding the key (the key itself is
      never stored here, nor in records or files); None = LiteLLM's provider default
      (``OPENAI_API_KEY``, ``ANTHROPIC_API_KEY``, ...).
    * `timeout_s`: HTTP timeout of the first attempt; attempt n gets ``timeout_s × n`` (as the
      reference).
    * `max_retries`: retries after the first attempt on transient errors, so
      ``max_retries + 1`` attempts in all. The default 2 gives the reference's 3 attempts.
    * `max_concurrency`: requests in flight per model (further requests queue).
    * `temperature`: a float is always sent; None is never sent; ``"auto"`` follows the
      reference (0 for model names starting gpt/o1/o3/o4, nothing otherwise).
    * `max_tokens`: completion limit; None = not sent.
    * `extra_params`: merged into every call (e.g. ``{"extra_body": {...}, "top_p": 0.9}``).
    * `grammar`: constrained decoding: send a GBNF grammar built from the menu
      (``extra_body.grammar``, understood by llama.cpp's server).
    * `cache_dir`: on-disk response cache folder; None = no cache.
    * `seed`: sent as ``seed + sample_index`` when set; also seeds the ``random`` built-in.
    * `backoff_s` / `backoff_max_s`: exponential backoff with full jitter between retries
      (``random(0, min(backoff_max_s, backoff_s × 2^n))``).
    * `max_reply_chars`: longer replies are cut to this length; the number of characters
      dropped is `ModelReply.truncated_chars`, never a note in the text.
    * `transport`: ``"litellm"`` (default) or ``"http"``: ``openai/NAME`` models posted straight
      to ``{api_base}/chat/completions``, for runs the LiteLLM client's CPU cost would bound.
    """

    api_base: str | None = None
    api_key_env: str | None = None
    timeout_s: float = 180.0
    max_retries: int = 2
    max_concurrency: int = 16
    temperature: float | str | None = TEMPERATURE_AUTO
    max_tokens: int | None = None
    extra_params: dict[str, Any] = field(default_factory=dict)
    grammar: bool = False
    cache_dir: str | Path | None = None
    seed: int | None = None
    backoff_s: float = 1.0
    backoff_max_s: float = 30.0
    max_reply_chars: int = 16_384
    transport: str = "litellm"

    def __post_init__(self) -> None:
        # A private copy, so later changes to the caller's dict cannot leak into a run.
        object.__setattr__(self, "extra_params", dict(self.extra_params or {}))
        if self.cache_dir is not None:
            object.__setattr__(self, "cache_dir", Path(self.cache_dir))
        if self.timeout_s <= 0:
            raise ValueError(f"timeout_s must be > 0, got {self.timeout_s}")
        if self.max_retries < 0:
            raise ValueError(f"max_retries must be >= 0, got {self.max_retries}")
        if self.max_concurrency < 1:
            raise ValueError(f"max_concurrency must be >= 1, got {self.max_concurrency}")
        if self.backoff_s < 0 or self.backoff_max_s < 0:
            raise ValueError("backoff_s and backoff_max_s must be >= 0")
        if self.max_reply_chars < 1:
            raise ValueError(f"max_reply_chars must be >= 1, got {self.max_reply_chars}")
        if self.transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {', '.join(TRANSPORTS)}, "
                             f"got {self.transport!r}")
        if isinstance(self.temperature, str) and self.temperature != TEMPERATURE_AUTO:
            raise ValueError(
                f"temperature must be a number, None or {TEMPERATURE_AUTO!r}, "
                f"got {self.temperature!r}"
            )
        if self.api_key_env is not None and not self.api_key_env.isidentifier():
            # Catches the easy mistake of passing the key itself instead of the variable name.
            raise ValueError("api_key_env must be the NAME of an environment variable")

    @property
    def max_attempts(self) -> int:
        """Attempts in all: the first plus `max_retries`."""
        return self.max_retries + 1

    def api_key(self) -> str | None:
        """The key from `api_key_env`, or None when unset (LiteLLM then uses its defaults)."""
        if not self.api_key_env:
            return None
        return os.environ.get(self.api_key_env) or None

    def call_key(self) -> str | None:
        """The key to send: `api_key()`; for a local `api_base` without `api_key_env`, a
        placeholder (so a provider key in the environment never goes to a local server);
        None otherwise (LiteLLM then reads the provider's variable)."""
        if self.api_key_env:
            return self.api_key()
        return LOCAL_PLACEHOLDER_KEY if is_local_url(self.api_base) else None

    def secrets(self) -> list[str]:
        """Every secret these settings carry: the key, values under secret-looking names in
        `extra_params` (``api_key``, ``Authorization`` headers, …), URL credentials."""
        return [v for v in (self.api_key(), *named_secrets(self.extra_params),
                            *url_credentials(self.api_base)) if v]

    def endpoint(self) -> tuple[str | None, dict[str, str]]:
        """`api_base` without ``user:password@``, and the headers those credentials become
        (HTTP Basic authorization; clients do not send URL credentials themselves)."""
        if not url_credentials(self.api_base):
            return self.api_base, {}
        parts = urlsplit(self.api_base)
        user, password = unquote(parts.username or ""), unquote(parts.password or "")
        token = base64.b64encode(f"{user}:{password}".encode()).decode("ascii")
        url = urlunsplit(parts._replace(netloc=parts.netloc.rpartition("@")[2]))
        return url, {"Authorization": f"Basic {token}"}

    def temperature_for(self, model: str) -> float | None:
        """The temperature to send for `model`, or None to send none."""
        if self.temperature == TEMPERATURE_AUTO:
            name = model.rsplit("/", 1)[-1].lower()
            return 0.0 if name.startswith(_REFERENCE_T0_PREFIXES) else None
        return None if self.temperature is None else float(self.temperature)

    def to_record(self) -> dict[str, Any]:
        """A JSON-safe description for run metadata: no key, only the variable's name."""
        record = {f.name: getattr(self, f.name) for f in fields(self)}
        # extra_params may carry headers or tokens a user put there by hand; the endpoint,
        # user:password@.
        record["extra_params"] = redact_named(_json_safe(self.extra_params))
        record["api_base"] = redact_url(self.api_base)
        record["cache_dir"] = None if self.cache_dir is None else str(self.cache_dir)
        return redact_obj(record, self.secrets())  # type: ignore[return-value]


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return repr(value)
