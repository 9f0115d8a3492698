"""`TaskConfigError`: one error type for everything that can go wrong reading task configs.

Messages always name the file, and the failing field when there is one, so a broken config in
a folder of hundreds can be found and fixed without a debugger.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from pydantic import ValidationError

# The model's own checks raise ValueError("goal_predicates[1].object: alias ...").
_FIELD_PREFIX = re.compile(r"^(?P<field>[A-Za-z_][\w\[\].]*): (?P<what>.+)$", re.DOTALL)
_INDEX = re.compile(r"\[(\d+)\]")


class TaskConfigError(ValueError):
    """A task config (or an index/subset file) that cannot be loaded or used.

    `path` is the file (or source) at fault, `field` the dotted path of the failing field
    (`init_state.objects`, `agents.0.id`), or None when the problem is not about one field.
    """

    def __init__(self, path: str | Path, what: str, field: str | None = None) -> None:
        self.path = str(path)
        self.field = field
        self.what = what
        super().__init__(self.__str__())

    def __str__(self) -> str:
        if self.field:
            return f"{self.path}: {self.field}: {self.what}"
        return f"{self.path}: {self.what}"

    def __reduce__(self) -> tuple[Any, ...]:
        # Keep the error picklable (worker processes send it back to the parent).
        return (type(self), (self.path, self.what, self.field))


def dotted(loc: tuple[int | str, ...] | list[int | str]) -> str:
    """A pydantic location as a dotted path: `("agents", 0, "id")` → `agents.0.id`."""
    return ".".join(str(part) for part in loc)


def from_validation_error(path: str | Path, exc: ValidationError) -> TaskConfigError:
    """Convert a pydantic error into a `TaskConfigError` naming the first failing field."""
    errors = exc.errors(include_url=False)
    field, what = _describe(errors[0])
    if len(errors) > 1:
        more = len(errors) - 1
        what += f" (and {more} more error{'s' if more > 1 else ''})"
    return TaskConfigError(path, what, field)


def from_json_error(path: str | Path, exc: json.JSONDecodeError) -> TaskConfigError:
    """Convert a JSON syntax error into a `TaskConfigError` giving line and column."""
    return TaskConfigError(
        path, f"invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
    )


def _describe(error: dict[str, Any]) -> tuple[str | None, str]:
    """(field, what) for one pydantic error entry."""
    field = dotted(error["loc"]) or None
    cause = (error.get("ctx") or {}).get("error")
    if error["type"] == "value_error" and cause is not None:
        # Model-level validators have an empty loc; the field is the message's prefix.
        field_in_text, what = _split_field(str(cause))
        return field_in_text or field, what
    what = error["msg"]
    if error["type"] != "missing" and _is_scalar(error.get("input")):
        what += f" (got {type(error['input']).__name__} {error['input']!r})"
    return field, what


def _split_field(message: str) -> tuple[str | None, str]:
    """Split `"goal_predicates[1].object: alias ..."` into (`goal_predicates.1.object`, rest)."""
    match = _FIELD_PREFIX.match(message)
    if not match:
        return None, message
    return _INDEX.sub(r".\1", match["field"]), match["what"]


def _is_scalar(value: Any) -> bool:
    # Only small values are echoed; dumping a whole nested object would drown the message.
    return (
        value is None
        or isinstance(value, (bool, int, float))
        or (isinstance(value, str) and len(value) <= 60)
    )
