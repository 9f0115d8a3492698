"""What a `run.json` must hold for its readers (the report, the export, the viewer, a
resume): the fields they read, each of the type they read it as, checked with pydantic.

Every field may be absent (earlier layouts lack some); fields no reader reads are kept as
they are. A record with a field of another type (``"plan": {"models": 5}``) is refused in one
line naming the field, so that no reader meets it later as a traceback.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

Texts = list[str] | None
Settings = dict[str, Any] | None  # a group of settings: read by name, values shown as text
#: As the request bounds a run's epochs, with room: a plan's count must stay a number.
MAX_EPOCHS = 10**6


class _Part(BaseModel):
    model_config = ConfigDict(strict=True, extra="allow")


class RecordedPlan(_Part):
    """`run.json`'s ``plan``: what the request resolved to."""

    task_ids: Texts = None
    models: Texts = None
    conditions: Texts = None
    sources: Texts = None
    arms: Texts = None
    planner_arms: Texts = None
    agent_models: dict[str, str] | None = None
    epochs: Annotated[int, Field(ge=1, le=MAX_EPOCHS)] | None = None


class RunRecord(_Part):
    """The fields of `run.json` that readers read."""

    record_version: int | None = None
    name: str | None = None
    created_at: str | None = None
    cocobench_agents: str | None = None
    command: str | None = None
    versions: dict[str, str | None] | None = None
    plan: RecordedPlan | None = None
    prompt_suite: dict[str, Any] | str | None = None
    prompt_suites: list[dict[str, Any]] | None = None
    planners: Settings = None
    request: Settings = None
    options: Settings = None
    model_settings: Settings = None
    cli_options: Settings = None
    temperature_sent: Settings = None


def record_error(record: dict[str, Any]) -> str | None:
    """Why `record` (a JSON object) is not a run record its readers can read, in a few words
    naming the field; None when it is."""
    try:
        RunRecord.model_validate(record)
    except ValidationError as exc:
        first = exc.errors(include_url=False)[0]
        where = ".".join(str(part) for part in first["loc"])
        more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        return f"{where}: {first['msg']}{more}"
    return None
