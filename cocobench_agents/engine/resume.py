"""Resuming a run: the request asked for now against the one `run.json` recorded.

A shaping setting (`setting_kinds`) that differs is refused, naming the setting and both
values; run settings take their new values. The recorded plan guards the sources too: a
folder of configs that changed on disk selects other instances, and is refused.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from cocobench_agents.engine.errors import RequestError
from cocobench_agents.engine.records import at_path, record_request, redacted_settings
from cocobench_agents.engine.request import RunRequest, iter_fields
from cocobench_agents.engine.resolve import ResolvedRun
from cocobench_agents.setting_kinds import flag_of, kind_of


def check_credentials_given(request: RunRequest) -> None:
    """Refuse a request that still holds a redacted credential: a resumed run whose
    ``--api-base`` or ``--extra`` carried one must be given it again."""
    for name in redacted_settings(request):
        flag = _flag(name)
        raise RequestError(f"--resume: the recorded {name} ({flag}) carried credentials, which "
                           f"are never stored: give {flag} again")


def check_recorded_code(recorded: RunRequest, chosen: Mapping[str, Any]) -> None:
    """Refuse to take the planners of a resumed run from its record when they are code
    (``FILE.py:NAME``, ``package.module:NAME``): a run folder is data, and one shared or
    downloaded must not make its author's code run. The command names them again
    (`chosen`: the values it was given, a config file's included), or the run is refused.
    Built-in and installed planners are taken from the record."""
    if any(chosen.get(name) is not None for name in ("conditions", "planners")):
        return
    code = planner_code(recorded.model_dump(mode="json"))
    if code:
        flag = "--conditions" if recorded.conditions is not None else "--planner"
        raise RequestError(f"--resume: the recorded run's planners are code ({', '.join(code)}), "
                           "which a run folder never makes run: give "
                           f"{flag} {','.join(code) if flag == '--conditions' else code[0]} "
                           "again to run that code")


def planner_code(request: Mapping[str, Any]) -> list[str]:
    """The planners that a request's values (`RunRequest` data, as recorded) name as code:
    ``FILE.py:NAME`` or ``package.module:NAME`` (a condition's or a planner's reference;
    built-in and installed planners are named without a colon)."""
    conditions = request.get("conditions")
    names = conditions if conditions is not None else request.get("planners")
    return [name for name in names or [] if isinstance(name, str) and ":" in name]


def refused_changes(recorded: RunRequest, asked: RunRequest) -> list[str]:
    """One line per shaping setting whose value `asked` changes (both canonical)."""
    before, after = record_request(recorded), record_request(asked)
    lines = []
    for path, info in iter_fields():
        if kind_of(info) != "shaping":
            continue
        old, new = at_path(before, path), at_path(after, path)
        if old != new:
            name = ".".join(path)
            lines.append(f"--resume: {name} ({_flag(name)}) {show_value(new)} differs from "
                         f"the recorded run ({show_value(old)}); it changes what is sent or "
                         "scored, so a resumed run keeps it: run without it, or into a new "
                         "--out")
    return lines


def check_same_plan(resolved: ResolvedRun, record: Mapping[str, Any]) -> None:
    """Refuse a resumed run whose request now resolves to other instances, models,
    conditions or arms than the recorded plan (e.g. a folder of configs that changed)."""
    recorded = record.get("plan") or {}
    current = resolved.plan_record()
    current.pop("planner_arms", None)
    if not current.get("arms") and "arms" not in recorded:
        current.pop("arms", None)
    for key, value in current.items():
        if key in recorded and recorded[key] != value:
            raise RequestError(
                f"--resume: {key} differ from the recorded run ({show_value(recorded[key])} "
                f"recorded, {show_value(value)} asked); run with the same options or "
                "without them")


def show_value(value: Any) -> str:
    """`value` as short JSON, for messages."""
    text = json.dumps(value)
    return text if len(text) < 80 else text[:77] + "..."


def _flag(name: str) -> str:
    for path, info in iter_fields():
        if ".".join(path) == name:
            return flag_of(info) or "the config file"
    return name
