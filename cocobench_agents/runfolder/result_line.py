"""What a valid line of `results.jsonl` is, checked with pydantic wherever lines are read.

A line is the benchmark's result of the episode (`EpisodeResult`: its fields are defined
there, once) under the run folder's own fields: the episode's key (`EpisodeKey`), its
trajectory's path, and the error of an episode that could not run. The benchmark's numbers and
texts are checked with strict types (`"model": 123` or `"task_success": "1"` make a line
invalid, never a second model or a success); every score may be absent (an episode that could
not run has none), and fields no reader checks are kept as they are.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model

from benchmark_adapter.metrics import EpisodeResult
from cocobench_agents.runfolder.episode_key import EpisodeKey
from cocobench_agents.runfolder.record import MAX_EPOCHS

Text = Annotated[str, Field(min_length=1)]
Number = float | None  # strict: an int is a number, a string or a bool is not
#: What a line's `construct_score` is not (a success score), said wherever a CS is shown:
#: the run's summary legend, the report's main table, the viewer's tooltips.
CS_NOTE = ("CS rates how the team coordinated, not whether it finished, so a team that fails "
           "can score 1.00: D1 is the reference makespan ÷ the team's makespan, capped at 1, "
           "and a team that stops early has a short makespan.")


class _Line(BaseModel):
    model_config = ConfigDict(strict=True, extra="allow")


class ConstructBlock(_Line):
    """One dimension's construct score (`cross_construct.D1`, …)."""

    score: Number = None
    status: str = "scored"


#: The run folder's own fields (the episode's key, its trajectory, an infrastructure error or
#: a planner error),
#: and the one a line must have: whether the episode succeeded.
_OWN: dict[str, Any] = {
    "model": (Text, ...),
    "condition": (Text, ...),
    "task_id": (Text, ...),
    "epoch": (Annotated[int, Field(ge=0, le=MAX_EPOCHS)] | None, 0),
    "arm": (Text | None, None),  # the prompt-suite arm, in a run comparing several
    "task_success": (Annotated[int, Field(ge=0, le=1)], ...),
    "infra_error": (str | None, None),
    "planner_error": (str | None, None),  # the strategy's code failed (`planner_error_line`)
    "trajectory": (Text | None, None),
}
#: The benchmark's blocks that readers look inside: usage totals, each dimension's score.
_BLOCKS: dict[str, Any] = {
    "usage": (dict[str, Number] | None, None),
    "cross_construct": (dict[str, ConstructBlock] | None, None),
}


def _checked_type(annotation: Any) -> Any:
    """The type a reader checks a field of `EpisodeResult` for: a number (int or float) for
    the benchmark's numbers, text for its texts, None for anything else (not checked)."""
    union = typing.get_origin(annotation) in (typing.Union, types.UnionType)
    kinds = set(typing.get_args(annotation)) if union else {annotation}
    kinds.discard(type(None))
    if kinds and kinds <= {int, float}:
        return Number
    if kinds == {str}:
        return str | None
    return None


def _benchmark_fields() -> dict[str, Any]:
    """The fields of `EpisodeResult` a line's readers check, each optional."""
    fields = {}
    for name, info in EpisodeResult.model_fields.items():
        if name in _OWN:
            continue
        checked = _BLOCKS.get(name) or (_checked_type(info.annotation), None)
        if checked[0] is not None:
            fields[name] = checked
    return fields


ResultLine = create_model(
    "ResultLine", __base__=_Line, __module__=__name__, **_OWN, **_benchmark_fields())
ResultLine.__doc__ = ("One episode's result line (an infrastructure error's line has the "
                      "key, the error and the task's identifiers only).")


def line_error(data: Any) -> str | None:
    """Why `data` (a parsed line) is not a valid result line, in a few words; None if it is."""
    if not isinstance(data, dict):
        return f"not a result (a JSON {type(data).__name__}, not an object)"
    try:
        ResultLine.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(part) for part in first["loc"]) or "line"
        more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        return f"invalid result: {where}: {first['msg']}{more}"
    return None


def line_identity(data: Any) -> tuple[str, str, str, int, str] | None:
    """(model, condition, task_id, epoch, arm) of a line, valid or not, when it says them."""
    if not isinstance(data, dict):
        return None
    names = [data.get(k) for k in ("model", "condition", "task_id")]
    epoch = data.get("epoch") or 0
    arm = data.get("arm") or ""
    if (all(isinstance(n, str) and n for n in names) and type(epoch) is int and epoch >= 0
            and isinstance(arm, str)):
        return names[0], names[1], names[2], epoch, arm
    return None


def infra_error_line(key: EpisodeKey, error: str, unrun: Mapping[str, Any]) -> dict[str, Any]:
    """The result line of an episode that could not run: its key, the error, and the
    benchmark's result of an episode that did not run (`metrics.unrun_result`)."""
    return {**key.as_dict(), "infra_error": error, **unrun}


def planner_error_line(key: EpisodeKey, error: str, unrun: Mapping[str, Any]) -> dict[str, Any]:
    """The result line of an episode the planner's own code ended (a node raised, returned a
    malformed record, or never ended): its key, the error naming the node, file and line, and
    the benchmark's result of an episode that did not finish (a failure). Not an
    infrastructure error: running it again fails the same way."""
    return {**key.as_dict(), "planner_error": error, **unrun}
