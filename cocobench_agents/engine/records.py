"""The request as `run.json` keeps it, read back, and as an equivalent command line.

`run.json` stores the request once, under ``"request"``: `RunRequest.model_dump` with
credentials redacted and paths canonical (`record_request`). `request_from_record` reads it
back with `RunRequest.model_validate`; run folders written by earlier versions (whose
settings were spread over ``cli_options``, ``options``, ``model_settings`` and an older
``request``) are read through `upgrade`, the documented converter (docs/python-api.md).
"""

from __future__ import annotations

import datetime as dt
import json
import platform
import shlex
from collections.abc import Mapping
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from cocobench_agents.engine.errors import RequestError
from cocobench_agents.engine.request import RunRequest, iter_fields, nest, value_at
from cocobench_agents.models.secrets import REDACTED, redact_named, redact_obj, redact_url
from cocobench_agents.runfolder.errors import RunFolderError
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.runfolder.upgrade import (
    RECORD_VERSION,
    is_current,
    unknown_version,
    version_1_settings,
)
from cocobench_agents.setting_kinds import flag_of
from cocobench_agents.version import __version__

if TYPE_CHECKING:
    from cocobench_agents.engine.resolve import ResolvedRun

PACKAGES = ("cocobench-agents", "langgraph", "litellm", "pydantic", "pillow", "ai2thor")


def run_record(resolved: ResolvedRun) -> dict[str, Any]:
    """`run.json`: the request (once), what it resolved to, and what a resume checks the
    code against (prompt-suite and planner-file hashes, package versions). No secret."""
    from cocobench_agents.graphs.plugins import planners_record
    from cocobench_agents.models import is_builtin

    request = resolved.request
    settings = request.model_settings
    recorded = record_request(request)
    return {
        "record_version": RECORD_VERSION,
        "name": request.out.name,
        "created_at": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "cocobench_agents": __version__,
        "versions": {"python": platform.python_version(), **_package_versions()},
        "request": recorded,
        "command": command_line(RunRequest.model_validate(recorded)),
        "plan": resolved.plan_record(),
        **_suites_record(resolved),
        # planners from the researcher's code: code, origin, file hash (guards a resume)
        "planners": planners_record(c.planner for c in resolved.conditions),
        # What "auto" resolved to, per remote model: the temperature sent (None: none sent).
        "temperature_sent": {
            model: settings.temperature_for(model)
            for model in dict.fromkeys(resolved.called_models) if not is_builtin(model)},
    }


def _suites_record(resolved: ResolvedRun) -> dict[str, Any]:
    """The prompt suite (spec, version, content hash, a folder's path), or with arms each
    arm's suite: what a resume checks the suites against."""
    arms = resolved.arms
    by_spec = {suite.spec: suite for suite in resolved.suites}
    if not arms:
        return {"prompt_suite": resolved.suites[0].record()}
    return {"prompt_suites": [{"arm": arm, **by_spec[spec].record()}
                              for arm, spec in arms.items()]}


def _package_versions() -> dict[str, str]:
    out = {}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out


def record_request(request: RunRequest) -> dict[str, Any]:
    """`request` as JSON for `run.json`: credentials redacted (a key is never in a request:
    only its variable's name)."""
    data = request.model_dump(mode="json")
    settings = data["model_settings"]
    settings["api_base"] = redact_url(settings["api_base"])
    settings["extra_params"] = redact_named(settings["extra_params"])
    return redact_obj(data, request.model_settings.secrets())  # type: ignore[return-value]


def redacted_settings(request: RunRequest) -> list[str]:
    """The settings of `request` that still hold a redacted credential (a resumed request
    whose credentials were not given again)."""
    data = request.model_dump(mode="json")
    return [".".join(path) for path, _ in iter_fields()
            if REDACTED in json.dumps(at_path(data, path))]


def request_from_record(record: Mapping[str, Any], where: Path) -> RunRequest:
    """The request recorded in `run.json` (at `where`, for messages), of any version."""
    if not isinstance(record.get("plan"), Mapping):
        raise RunFolderError(f"{where}: not a run record (no plan)")
    unknown = unknown_version(record)
    if unknown is not None:
        raise RunFolderError(f"{where}: {unknown}")
    data = record.get("request") if is_current(record) else upgrade(record)
    try:
        return RunRequest.model_validate(data)
    except ValidationError as exc:
        problems = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}"
                             for e in exc.errors(include_url=False))
        raise RequestError(f"{where}: the recorded request is not valid ({problems})") from None


def recorded_request(out: Path) -> RunRequest | None:
    """The request recorded in run folder `out`, of any version (None when it holds no
    run yet)."""
    folder = RunFolder(out)
    if not folder.record_path.is_file():
        return None
    return request_from_record(folder.run_record(), folder.record_path)


def upgrade(record: Mapping[str, Any]) -> dict[str, Any]:
    """The request of a `run.json` written before the one-request layout (version 1), as
    `RunRequest` data: its settings read by their names of today
    (`runfolder.upgrade.version_1_settings`: ``--planner`` → ``planners``, ``--timeout`` →
    ``model_settings.timeout_s``, ``--task``/``--suite`` → ``selection.sources``, …),
    nested as the request holds them.

    Options no field has (``no_preflight``, …) are dropped, and so is an unset option (null)
    whose field has a default of another kind: the field keeps its default.
    """
    flat = version_1_settings(record)
    defaults = {path[-1]: info.get_default(call_default_factory=True)
                for path, info in iter_fields()}
    return nest({name: value for name, value in flat.items() if name in defaults
                 and (value is not None or defaults[name] is None)})


def command_line(request: RunRequest) -> str:
    """An equivalent ``cocobench run …`` line: the flags of every setting that differs from
    its default (settings without a flag, in a config file only, are said in a comment)."""
    default = RunRequest(out=request.out)
    words = ["cocobench", "run"]
    file_only = []
    for path, info in iter_fields():
        value = value_at(request, path)
        if value == value_at(default, path) and path != ("out",):
            continue
        flag = flag_of(info)
        if flag is None:
            file_only.append(".".join(path))
            continue
        words += _flag_words(path[-1], flag, value)
    line = " ".join(shlex.quote(w) for w in words)
    if file_only:
        line += f"  # and in a config file: {', '.join(file_only)}"
    return line


def _flag_words(name: str, flag: str, value: Any) -> list[str]:
    if name == "sources":
        return ["--suite", value[0]] if len(value) == 1 else [
            w for v in value for w in ("--task", v)]
    if name == "preflight":
        return [] if value else ["--no-preflight"]
    if isinstance(value, bool):
        return [flag] if value else []
    if name == "agent_models":
        return [w for agent, model in value.items() for w in (flag, f"{agent}={model}")]
    if name == "conditions":
        return [flag, ",".join(value)]
    if name == "extra_params":
        return [flag, json.dumps(value, sort_keys=True)]
    if isinstance(value, list):
        return [w for v in value for w in (flag, str(v))]
    if value is None:
        return [flag, "none"] if name == "temperature" else []
    return [flag, str(value)]


def at_path(data: Mapping[str, Any], path: tuple[str, ...]) -> Any:
    """The value at `path` in a request's JSON form."""
    for part in path:
        data = data[part]
    return data
