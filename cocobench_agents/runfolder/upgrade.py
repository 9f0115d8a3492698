"""`run.json`'s layouts: the record version this code writes, and the settings of a record
written before it, read by the name each has now.

Version 2 (`RECORD_VERSION`) keeps the run's request once, under ``"request"``. Version 1
spread the settings over ``cli_options`` (every option of the command, by its option name)
or, older, over ``request`` (the plan's sources, models, conditions, …) and
``model_settings``. `version_1_settings` reads either by the setting names of today; the
engine nests them into its request (`engine.records.upgrade`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

#: `run.json`'s layout: 2 is the one-request layout.
RECORD_VERSION = 2

#: Options of the earlier command line whose request field has another name.
_RENAMED = {"planner": "planners", "obs_mode": "obs_modes", "prompt_suite": "prompt_suites",
            "task_id": "task_ids", "timeout": "timeout_s", "extra_json": "extra_params"}


#: The layouts this code reads (a version 1 record may not say its version).
KNOWN_VERSIONS = (None, 1, RECORD_VERSION)


def unknown_version(record: Mapping[str, Any]) -> str | None:
    """Why `record`'s layout cannot be read (a record version this code does not know, as
    one written by a later version), or None."""
    version = record.get("record_version")
    if version in KNOWN_VERSIONS and not isinstance(version, bool):
        return None
    known = ", ".join(str(v) for v in KNOWN_VERSIONS if v is not None)
    writer = record.get("cocobench_agents")
    by = f" (written by cocobench-agents {writer})" if isinstance(writer, str) else ""
    return (f"record_version {json.dumps(version)[:40]} is not one this version of "
            f"cocobench-agents reads ({known}){by}: use the version that wrote it")


def is_current(record: Mapping[str, Any]) -> bool:
    """Whether a `run.json` has this code's layout (its request under ``"request"``)."""
    return record.get("record_version") == RECORD_VERSION


def version_1_settings(record: Mapping[str, Any]) -> dict[str, Any]:
    """The settings of a `run.json` written before the one-request layout (version 1), by
    the leaf name of the setting each is now:

    * with ``cli_options`` (every option of the command, by its option name): each option
      becomes its setting (``--planner`` → ``planners``, ``--timeout`` → ``timeout_s``,
      ``--task``/``--suite`` → ``sources``, …);
    * older, without: ``request`` (the plan's sources, models, conditions, task ids, epochs,
      prompt suite, backend, step budget and ids) and ``model_settings``.

    ``out`` is ``"."`` when the record does not say it, and ``sources`` is absent when it
    names none. Options no setting has now (``no_preflight``, …) are kept: the reader drops
    them.
    """
    options = record.get("cli_options")
    if isinstance(options, Mapping):
        flat = {_RENAMED.get(k, k): v for k, v in options.items()}
        flat["sources"] = _listed(flat.pop("tasks", None)) or _listed(flat.pop("suite", None))
    else:
        old = _mapping(record.get("request"))
        flat = {**_mapping(record.get("model_settings")),
                "sources": _listed(old.get("tasks")) or _listed(old.get("suite")),
                "models": old.get("models"), "agent_models": old.get("agent_models"),
                "conditions": old.get("conditions"), "epochs": old.get("epochs"),
                "task_ids": old.get("task_id"), "prompt_suites": old.get("prompt_suite"),
                "backend": old.get("backend"), "max_steps": old.get("max_steps"),
                "stable_ids": old.get("stable_ids")}
    flat["out"] = flat.get("out") or "."
    if not flat["sources"]:
        flat.pop("sources")
    return flat


def _mapping(value: Any) -> Mapping[str, Any]:
    return value if isinstance(value, Mapping) else {}


def _listed(value: Any) -> list[str]:
    if value in (None, "", [], ()):
        return []
    return [value] if isinstance(value, str) else [str(v) for v in value]
