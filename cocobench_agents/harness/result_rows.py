"""What a valid line of `results.jsonl` is, checked with pydantic wherever lines are read.

Strict types: `"model": 123` or `"task_success": "1"` make a line invalid, never a second
model or a success. Fields the harness does not read are kept as they are.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

Text = Annotated[str, Field(min_length=1)]
Number = float | None  # strict: an int is a number, a string or a bool is not
#: What a line's `construct_score` is not (a success score), said wherever a CS is shown:
#: the run's summary legend, the report's main table, the viewer's tooltips.
CS_NOTE = ("CS rates how the team coordinated, not whether it finished, so a team that fails "
           "can score 1.00: D1 is the reference makespan ÷ the team's makespan, capped at 1, "
           "and a team that stops early has a short makespan.")


class _Row(BaseModel):
    model_config = ConfigDict(strict=True, extra="allow")


class ConstructBlock(_Row):
    """One dimension's construct score (`cross_construct.D1`, …)."""

    score: Number = None
    status: str = "scored"


class ResultRow(_Row):
    """One episode's result line (an infrastructure error's line has the first block only)."""

    model: Text
    condition: Text
    task_id: Text
    epoch: Annotated[int, Field(ge=0)] | None = 0
    arm: Text | None = None  # the prompt-suite arm, in a run comparing several
    task_success: Annotated[int, Field(ge=0, le=1)]
    infra_error: str | None = None
    trajectory: Text | None = None
    cell: str | None = None
    family: str | None = None
    dim: str | None = None
    planner: str | None = None
    obs_mode: str | None = None
    failure_kind: str | None = None
    agent_count: Number = None
    task_progress: Number = None
    legal_plan: Number = None
    construct_score: Number = None
    num_steps: Number = None
    num_invalid_action_ratio: Number = None
    dependency_violations: Number = None
    occupancy_conflicts: Number = None
    affordance_failures: Number = None
    illegal_skill: Number = None
    planner_steps: Number = None
    backend_errors: Number = None
    elapsed_s: Number = None
    usage: dict[str, Number] | None = None
    cross_construct: dict[str, ConstructBlock] | None = None


def row_error(data: Any) -> str | None:
    """Why `data` (a parsed line) is not a valid result line, in a few words; None if it is."""
    if not isinstance(data, dict):
        return f"not a result (a JSON {type(data).__name__}, not an object)"
    try:
        ResultRow.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(part) for part in first["loc"]) or "line"
        more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        return f"invalid result: {where}: {first['msg']}{more}"
    return None


def row_identity(data: Any) -> tuple[str, str, str, int, str] | None:
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
