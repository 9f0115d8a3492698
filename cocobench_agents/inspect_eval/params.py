"""The task's parameters (``-T name=value``): named as `cocobench run`'s options, they become
a `RunRequest`, validated by it with its messages. Settings Inspect owns (the model, epochs,
concurrency, limits, the log) are refused with the Inspect option that sets them; those with
no counterpart under Inspect (the worker watchdogs, Ray, the baselines) as not available."""

from __future__ import annotations

import re
from typing import Any

from inspect_ai._util.error import PrerequisiteError

from benchmark_adapter.vocabulary import IMAGE
from cocobench_agents.api import request_of
from cocobench_agents.engine.errors import is_user_error
from cocobench_agents.engine.request import RunRequest

#: Where a run's folder would go: an Inspect task writes none (Inspect writes its log).
_NO_FOLDER = "/nonexistent/cocobench-inspect"
#: The model string of the planned episodes; each sample's real one is Inspect's model.
PLACEHOLDER_MODEL = "inspect"
#: `cocobench run` options Inspect sets instead, and how.
INSPECT_OWNS = {
    "model": "--model PROVIDER/MODEL", "models": "--model PROVIDER/MODEL",
    "agent_model": "--model-role AGENT=PROVIDER/MODEL",
    "agent_models": "--model-role AGENT=PROVIDER/MODEL",
    "epochs": "--epochs N", "out": "--log-dir DIR", "jobs": "--max-samples N",
    "workers": "--max-samples N", "executor": "--max-samples N",
    "max_cost": "--cost-limit USD", "max_total_tokens": "--token-limit N",
    "episode_timeout": "--time-limit S",
    "max_retries": "--max-retries N", "timeout": "--timeout S", "timeout_s": "--timeout S",
    "max_concurrency": "--max-connections N", "api_base": "--model-base-url URL",
    "api_key_env": "the provider's key variable", "transport": "--model PROVIDER/MODEL",
    "cache": "Inspect's own response cache", "cache_dir": "Inspect's own response cache",
}
_IN_PROCESS = "Inspect runs the samples in its own process; --max-samples N sets how many at once"
#: `cocobench run` options with no counterpart under Inspect, and why.
NOT_UNDER_INSPECT = {
    "episode_memory": "Inspect runs the samples in its own process, with no worker to stop",
    "stall_timeout": "Inspect runs the samples in its own process, with no worker to stop",
    "ray_address": _IN_PROCESS, "ray_wait": _IN_PROCESS, "thor_gpus_per_worker": _IN_PROCESS,
    "baselines": "run the reference rows with `cocobench run --baselines`",
}
#: How our messages name a setting: its option, then its field.
_OPTION_NAMED = re.compile(r"--[\w-]+ \((?P<name>\w+)\)")

class TaskParameterError(PrerequisiteError, ValueError):
    """A ``-T`` parameter the task cannot run with: the message names it. (A
    `PrerequisiteError`: Inspect's command prints its message alone, no traceback.)"""

    def __init__(self, message: str) -> None:
        ValueError.__init__(self, message)
        self.message = message


def task_request(params: dict[str, Any]) -> RunRequest:
    """The request the task's parameters stand for (`TaskParameterError` naming the
    parameter otherwise). ``suite`` is another name of ``task`` (the instances' source)."""
    given = {name: value for name, value in params.items() if value is not None}
    for name in given:
        if name in INSPECT_OWNS:
            raise TaskParameterError(
                f"-T {name}: Inspect sets this for a CoCoBench task; use {INSPECT_OWNS[name]}")
        if name in NOT_UNDER_INSPECT:
            raise TaskParameterError(
                f"-T {name}: not available under Inspect ({NOT_UNDER_INSPECT[name]})")
    if "suite" in given and "task" in given:
        raise TaskParameterError("-T suite and -T task name the same setting (the instances' "
                                 "source): give one")
    source = given.pop("suite", None) or given.pop("task", None)
    if isinstance(source, str) and "," in source:
        source = [part.strip() for part in source.split(",") if part.strip()]
    conditions = given.pop("conditions", None)
    planners = given.pop("planner", None)
    obs = given.pop("obs", None)
    if "prompt_suite" in given:
        given["prompt_suite"] = _listed(given["prompt_suite"])
    if planners is not None and conditions is not None:
        raise TaskParameterError("-T planner and -T conditions both choose the conditions: "
                                 "give one")
    if planners is not None:  # each planner under each observation mode of -T obs
        given["planners"] = _listed(planners)
        conditions = _listed(obs or IMAGE)  # `request_of` reads the modes from them
    elif obs is not None:
        raise TaskParameterError("-T obs goes with -T planner (or name conditions such as "
                                 "-T conditions=C0_image,C0_blind)")
    try:
        kwargs = {} if conditions is None else {"conditions": conditions}
        request = request_of(source, models=[PLACEHOLDER_MODEL], out=_NO_FOLDER, **kwargs,
                             **given)
    except TypeError as exc:  # an unknown keyword
        raise TaskParameterError(f"{_unknown(exc)} (parameters are named as `cocobench "
                                 "run`'s options; see docs/inspect.md)") from None
    except Exception as exc:
        if not is_user_error(exc):
            raise
        raise TaskParameterError(_as_parameters(str(exc))) from None
    return request


def _as_parameters(message: str) -> str:
    """Our message with each option as the task parameter it is (``--max-steps
    (max_steps)`` → ``-T max_steps``)."""
    return _OPTION_NAMED.sub(lambda m: f"-T {m['name']}", message)


def _unknown(exc: TypeError) -> str:
    name = str(exc).partition("option ")[2].partition(" ")[0].strip("'\"")
    return f"-T {name}: no such parameter" if name else str(exc)


def _listed(value: Any) -> list[str]:
    if isinstance(value, str):
        return [part.strip() for part in value.split(",") if part.strip()]
    return [str(v) for v in value]
