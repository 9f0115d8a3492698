"""Which runs may share a report row: a (model, condition) row merges episodes of several
runs only when those runs asked the model the same way and scored it the same way.

Otherwise (say one run used temperature 0 and the other 0.7) the merged row would describe
neither; the report refuses, or, when asked (``--arms``), labels each run's models apart so
that every run is its own arm.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from cocobench_agents.engine.request import iter_fields
from cocobench_agents.models.builtin import is_builtin
from cocobench_agents.runfolder.upgrade import is_current
from cocobench_agents.setting_kinds import kind_of

#: The request's settings that say what runs (the instances, a row's model and condition, the
#: arms, the epochs, the baselines), not how: runs that differ in them still share rows.
WHAT_RUNS = ("selection", "models", "planners", "obs_modes", "conditions", "prompt_suites",
             "epochs", "baselines")
#: The oracle baseline's rows: a planner, which calls no model.
ORACLE_ROWS = "oracle"


def _shaping(group: tuple[str, ...]) -> tuple[str, ...]:
    """The shaping settings (`setting_kinds`) directly in the request's `group` (() for its
    top level), by name."""
    return tuple(path[-1] for path, info in iter_fields() if path[:-1] == group
                 and kind_of(info) == "shaping" and path[-1] not in WHAT_RUNS)


#: `run.json` options that change the episodes of every model (`agent_models`: a team's
#: other seats; a human–AI team and a model team are not one row).
RUN_OPTIONS = _shaping(())
#: `run.json` model settings that change what a remote model is sent (or what is kept of
#: its replies); built-in models ignore them.
MODEL_SETTINGS = _shaping(("model_settings",))


def recorded_settings(record: Mapping[str, Any]) -> tuple[Mapping[str, Any],
                                                         Mapping[str, Any]]:
    """A `run.json`'s run options (backend, step budget, …) and model settings: both in its
    ``request`` (the one-request layout, `upgrade.RECORD_VERSION`), or apart (earlier
    runs)."""
    if is_current(record):
        request = _mapping(record.get("request"))
        return request, _mapping(request.get("model_settings"))
    return _mapping(record.get("options")), _mapping(record.get("model_settings"))


def row_settings(record: Mapping[str, Any], model: str, arm: str = "") -> dict[str, Any]:
    """What a run's `run.json` says shapes the episodes of `model` (in the run's
    prompt-suite `arm`, if it has arms; missing: None)."""
    options, model_settings = recorded_settings(record)
    settings = {name: options[name] for name in RUN_OPTIONS if name in options}
    suite = _suite(record, arm)
    settings["prompt_suite"] = suite.get("spec")
    if suite.get("content_hash"):  # older runs did not record it
        settings["prompt_suite content"] = suite["content_hash"]
    if not is_builtin(model) and model.partition(":")[0] != ORACLE_ROWS:
        settings.update({name: model_settings.get(name) for name in MODEL_SETTINGS})
    return settings


def difference(a: Mapping[str, Any], b: Mapping[str, Any]) -> str | None:
    """The first setting two `row_settings` disagree on, as ``name (a vs b)``; None when
    they agree. A setting only one run records is not compared (an older run)."""
    for name, value in a.items():
        if name in b and value != b[name]:
            return f"{name} ({_show(value)} vs {_show(b[name])})"
    return None


def arm_label(model: str, arm: str | Path) -> str:
    """`model` as one arm: of a run (``--arms``), labelled by the run folder as given, or
    of a run's prompt-suite arms, labelled by the suite (``MODEL @cocobench-v1+no-hint``)."""
    return f"{model} @{arm}"


def _suite(record: Mapping[str, Any], arm: str) -> Mapping[str, Any]:
    """The `run.json` record of the prompt suite of `arm` (the run's one suite without)."""
    suites = record.get("prompt_suites")
    if isinstance(suites, list):
        return next((s for s in suites if isinstance(s, Mapping) and s.get("arm") == arm), {})
    suite = record.get("prompt_suite")
    return suite if isinstance(suite, Mapping) else {"spec": suite}


def _mapping(value: Any) -> Mapping[str, Any]:
    return value if isinstance(value, Mapping) else {}


def _show(value: Any) -> str:
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= 60 else text[:57] + "..."
