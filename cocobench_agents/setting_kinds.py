"""The two kinds of run setting, marked on each field where it is defined.

A **shaping** setting changes what is sent to a model or how an episode is scored (the
instances, the models, the prompt suite, the temperature, …): the episodes of a run must all
share it, so a resumed run refuses a different value. A **run** setting only changes how the
run goes (concurrency, timeouts, spend limits, where episodes execute): a resume may change it.

Every field of `RunRequest` and of the settings nested in it is made with `shaping()` or
`run_setting()`; `kind_of` reads the mark back. The mark lives in the field's JSON-schema
extras, so it also shows in ``RunRequest.model_json_schema()``.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field
from pydantic.fields import FieldInfo

Kind = Literal["shaping", "run"]
KIND_KEY = "x-kind"
FLAG_KEY = "x-flag"
#: The prefix of the variables that set `cocobench run`'s options.
RUN_VARIABLE_PREFIX = "COCOBENCH_RUN_"


def run_variable(flag: str) -> str:
    """The variable that sets option `flag` (``--max-steps``: ``COCOBENCH_RUN_MAX_STEPS``)."""
    return RUN_VARIABLE_PREFIX + flag.split("/")[0].lstrip("-").replace("-", "_").upper()


def shaping(default: Any = ..., *, flag: str | None = None, **kwargs: Any) -> Any:
    """A field that changes what is sent or scored (a resume refuses a change). `flag` is the
    ``cocobench run`` option that sets it, if any."""
    return _field("shaping", default, flag, kwargs)


def run_setting(default: Any = ..., *, flag: str | None = None, **kwargs: Any) -> Any:
    """A field of how the run goes (a resume accepts a change)."""
    return _field("run", default, flag, kwargs)


def _field(kind: Kind, default: Any, flag: str | None, kwargs: dict[str, Any]) -> Any:
    extra: dict[str, Any] = {KIND_KEY: kind}
    if flag:
        extra[FLAG_KEY] = flag
    if "default_factory" in kwargs:
        return Field(json_schema_extra=extra, **kwargs)
    return Field(default, json_schema_extra=extra, **kwargs)


def kind_of(info: FieldInfo) -> Kind:
    """The kind a field was marked with (`TypeError` for an unmarked one: every setting must
    say)."""
    extra = info.json_schema_extra
    if not isinstance(extra, dict) or extra.get(KIND_KEY) not in ("shaping", "run"):
        raise TypeError(f"field {info!r} is not marked shaping() or run_setting()")
    return extra[KIND_KEY]  # type: ignore[return-value]


def flag_of(info: FieldInfo) -> str | None:
    """The ``cocobench run`` option that sets a field (None: config files only)."""
    extra = info.json_schema_extra
    return extra.get(FLAG_KEY) if isinstance(extra, dict) else None  # type: ignore[return-value]
