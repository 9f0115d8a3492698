"""`ModelSettings`: how remote models are called (endpoint, key, timeouts, retries, sampling)."""

from __future__ import annotations

import ipaddress
import json
import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal, get_args
from urllib.parse import urlsplit, urlunsplit

from pydantic import BaseModel, ConfigDict, ValidationError, field_validator

from cocobench_agents.setting_kinds import flag_of, run_setting, run_variable, shaping

from .builtin import is_builtin
from .secrets import (
    basic_token,
    named_secrets,
    redact_named,
    redact_obj,
    redact_url,
    secret_forms,
    url_credentials,
    url_parts,
)

#: `temperature` value meaning "as the reference": 0 for OpenAI model names starting with
#: gpt/o1/o3/o4, not sent otherwise.
TEMPERATURE_AUTO = "auto"
_REFERENCE_T0_PREFIXES = ("gpt", "o1", "o3", "o4")
#: The key sent to a local server when no `api_key_env` is given (OpenAI-style clients
#: refuse to send a request without one; local servers rarely check it).
LOCAL_PLACEHOLDER_KEY = "no-key-required"
#: How remote models are called: through LiteLLM (the default, any provider), or ``http``, a
#: lean OpenAI-compatible client for high-concurrency runs (see `openai_http`), or ``inspect``,
#: the model of a running Inspect eval (see `inspect_client`).
Transport = Literal["litellm", "http", "inspect"]
#: The transports' names (the ``--transport`` choice).
TRANSPORTS: tuple[str, ...] = get_args(Transport)
#: The transports that call a model's endpoint themselves (``inspect`` asks Inspect's model,
#: which calls it): what the endpoint tests run against a local server.
ENDPOINT_TRANSPORTS = ("litellm", "http")


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


class ModelSettings(BaseModel):
    """How the remote models of a run are called (shared by every model of the run).

    Built-in models ignore these. Each field says whether it shapes what is sent (a resumed
    run keeps it) or only how the calls go (`setting_kinds`).
    """

    # Numbers must be finite: a `nan` temperature was accepted and failed every call later
    # as a "transient" error.
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    api_base: str | None = shaping(
        None, flag="--api-base",
        description="Endpoint URL (e.g. http://127.0.0.1:8080/v1 for a local llama.cpp or "
                    "vLLM server); unset: the provider's default. user:password@ in it is sent "
                    "as HTTP Basic authorization and never stored.")
    api_key_env: str | None = run_setting(
        None, flag="--api-key-env",
        description="The NAME of the environment variable holding the API key (never the "
                    "key itself); unset: LiteLLM's provider default (OPENAI_API_KEY, ...).")
    timeout_s: float = run_setting(
        180.0, flag="--timeout", gt=0,
        description="HTTP timeout of a call's first attempt in seconds; attempt n gets "
                    "timeout_s × n (as the reference).")
    max_retries: int = run_setting(
        2, flag="--max-retries", ge=0,
        description="Retries after the first attempt on transient errors (2: the "
                    "reference's 3 attempts).")
    max_concurrency: int = run_setting(
        16, flag="--max-concurrency", ge=1,
        description="Model calls in flight per model (further calls queue).")
    temperature: float | Literal["auto"] | None = shaping(
        TEMPERATURE_AUTO, flag="--temperature",
        description="A number is always sent; null never; 'auto' follows the reference (0 "
                    "for model names starting gpt/o1/o3/o4, nothing otherwise).")
    max_tokens: int | None = shaping(
        None, flag="--max-tokens", ge=1,
        description="Completion token limit per call; unset: not sent.")
    extra_params: dict[str, Any] = shaping(
        default_factory=dict, flag="--extra",
        description="Merged into every call, e.g. {\"top_p\": 0.9} (a JSON object; secrets "
                    "under names like api_key are never stored).")
    grammar: bool = shaping(
        False, flag="--grammar",
        description="Constrain replies to the menu ids with a GBNF grammar "
                    "(extra_body.grammar, understood by llama.cpp's server).")
    cache_dir: Path | None = run_setting(
        None, flag="--cache", description="On-disk response cache folder; unset: no cache.")
    seed: int | None = shaping(
        None, flag="--seed",
        description="Sent as seed + sample index when set; also seeds the random built-in.")
    backoff_s: float = run_setting(
        1.0, ge=0, description="Exponential backoff with full jitter between retries: "
                               "random(0, min(backoff_max_s, backoff_s × 2^n)).")
    backoff_max_s: float = run_setting(30.0, ge=0, description="The backoff's ceiling.")
    max_reply_chars: int = shaping(
        16_384, ge=1, description="Longer replies are cut to this length (the characters "
                                  "dropped are counted, never noted in the text).")
    transport: Transport = shaping(
        "litellm", flag="--transport",
        description="How remote models are called: LiteLLM (any provider), or http, a lean "
                    "OpenAI-compatible client for openai/NAME models (for high --jobs "
                    "against a local server; see docs/models.md), or inspect, the model "
                    "of a running Inspect eval (docs/inspect.md).")

    @field_validator("extra_params", mode="before")
    @classmethod
    def _json_object(cls, value: Any) -> Any:
        """``--extra`` and environment variables give the object as JSON text."""
        if isinstance(value, str):
            try:
                value = json.loads(value, parse_constant=_refuse_constant) \
                    if value.strip() else {}
            except json.JSONDecodeError as exc:
                raise ValueError(f"not JSON: {exc}") from None
            except RecursionError:
                raise ValueError("nested too deeply") from None
        if not isinstance(value, dict):
            raise ValueError("must be a JSON object")
        if not _all_finite(value):
            raise ValueError("holds a number that is not finite (NaN or Infinity)")
        return value

    @field_validator("temperature", mode="before")
    @classmethod
    def _temperature(cls, value: Any) -> Any:
        """A finite number, ``auto`` or ``none`` (``--temperature none`` sends none; ``null``
        in a config file), one message for anything else."""
        expected = f"expected a finite number, {TEMPERATURE_AUTO!r} or none"
        if isinstance(value, str):
            if value.lower() in ("none", "null"):
                return None
            if value == TEMPERATURE_AUTO:
                return value
            try:
                value = float(value)
            except ValueError:
                raise ValueError(f"{expected}, got {value!r}") from None
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"{expected}, got {value!r}")
        return value

    @field_validator("api_key_env")
    @classmethod
    def _variable_name(cls, value: str | None) -> str | None:
        # Catches the easy mistake of passing the key itself instead of the variable name.
        if value is not None and not value.isidentifier():
            raise ValueError("must be the NAME of an environment variable")
        return value

    @classmethod
    def from_run_variables(cls, environ: Mapping[str, str] | None = None) -> ModelSettings:
        """The settings the ``COCOBENCH_RUN_*`` variables of `environ` (default: this process's)
        give, as `cocobench run` reads them (`--api-base`: ``COCOBENCH_RUN_API_BASE``; an empty
        one is unset, as click has it), the defaults for the rest. A bad value is a
        `ValueError` naming its variable (not the value: an endpoint may carry a password)."""
        environ = os.environ if environ is None else environ
        variables = {name: run_variable(flag) for name, info in cls.model_fields.items()
                     if (flag := flag_of(info)) is not None}
        given = {name: environ[v] for name, v in variables.items() if environ.get(v)}
        try:
            return cls.model_validate(given)
        except ValidationError as exc:
            raise ValueError("; ".join(f"{variables[e['loc'][0]]}: {e['msg']}"
                                       for e in exc.errors())) from None

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
        """Every secret these settings carry, in every form it may be seen in
        (`secret_forms`, `url_credentials`): the key, values under secret-looking names in
        `extra_params` (``api_key``, ``Authorization`` headers, …), URL credentials and the
        HTTP Basic token they are sent as."""
        given = [v for v in (self.api_key(), *named_secrets(self.extra_params)) if v]
        return [*(form for value in given for form in secret_forms(value)),
                *url_credentials(self.api_base)]

    def endpoint(self) -> tuple[str | None, dict[str, str]]:
        """`api_base` without ``user:password@``, and the headers those credentials become
        (HTTP Basic authorization; clients do not send URL credentials themselves)."""
        given = url_parts(self.api_base)
        if given is None:
            return self.api_base, {}
        parts = urlsplit(self.api_base)
        url = urlunsplit(parts._replace(netloc=parts.netloc.rpartition("@")[2]))
        return url, {"Authorization": f"Basic {basic_token(*given)}"}

    def temperature_for(self, model: str) -> float | None:
        """The temperature to send for `model`, or None to send none."""
        if self.temperature == TEMPERATURE_AUTO:
            name = model.rsplit("/", 1)[-1].lower()
            return 0.0 if name.startswith(_REFERENCE_T0_PREFIXES) else None
        return None if self.temperature is None else float(self.temperature)

    def to_record(self) -> dict[str, Any]:
        """A JSON-safe description for run metadata: no key, only the variable's name."""
        record = self.model_dump(mode="json", exclude={"extra_params"})
        # extra_params may carry headers or tokens a user put there by hand; the endpoint,
        # user:password@.
        record["extra_params"] = redact_named(_json_safe(self.extra_params))
        record["api_base"] = redact_url(self.api_base)
        return redact_obj(record, self.secrets())  # type: ignore[return-value]


def unset_sampling_notice(settings: ModelSettings, models: Iterable[str]) -> str | None:
    """A sentence naming the remote models among `models` whose calls carry no temperature
    (neither `temperature` nor `extra_params` sets one): the provider samples at its own
    default, often above 0, so their episodes are not reproducible. None when there is none.
    `models` are models a seat calls (not the label of the rows of a planner that calls
    none: `graphs.NO_MODEL`)."""
    unset = [m for m in dict.fromkeys(models) if not is_builtin(m)
             and settings.temperature_for(m) is None
             and "temperature" not in settings.extra_params]
    if not unset:
        return None
    why = ("--temperature auto sends 0 only to gpt/o1/o3/o4 names"
           if settings.temperature == TEMPERATURE_AUTO else "--temperature none")
    return (f"sampling is unset for {', '.join(unset)}: no temperature is sent ({why}), so "
            "the provider samples at its own default and the run is not reproducible; "
            "--temperature 0 fixes it")


def _refuse_constant(name: str) -> Any:
    """`json.loads`'s hook for ``NaN``, ``Infinity`` and ``-Infinity`` (not JSON numbers)."""
    raise ValueError(f"{name} is not a number JSON allows")


def _all_finite(value: Any) -> bool:
    """Whether every float in a JSON-like value is finite (iterative: any depth)."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, float) and not math.isfinite(item):
            return False
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
    return True


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return repr(value)
