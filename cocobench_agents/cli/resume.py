"""What `cocobench run` records of its options, and how `--resume` restores them.

Every option is recorded in `run.json` (secrets redacted). On `--resume`, an option not given
on the command line takes its recorded value; one given that changes what is sent to a model
or how it is scored, and differs from the recorded value, is refused (exit 2, naming it).
Options that only change how the run goes (jobs, timeouts, spend limits, …) may change.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
from click.core import ParameterSource

from cocobench_agents.models.secrets import REDACTED, redact_named, redact_url

#: Options that change what is sent or scored: a resumed run must keep them.
SHAPING = frozenset({
    "tasks", "suite", "eval_set", "only_cell", "only_family", "only_dim", "task_id", "limit",
    "missing", "planner", "obs_mode", "conditions", "models", "agent_models",
    "baselines", "epochs", "prompt_suite", "backend", "max_steps",
    "stable_ids", "api_base", "transport", "temperature", "max_tokens", "grammar", "seed",
    "extra_json",
})
#: What belongs to one invocation only.
NOT_RECORDED = frozenset({"out", "resume", "retry_errors", "no_preflight"})
#: Options naming files or folders: recorded absolute, so a resume works from anywhere.
PATHS = frozenset({"tasks", "suite", "cache_dir"})
#: Repeatable options that once took one value: one value is recorded as a string (as those
#: versions did, so their run folders resume), several as a list (the arms of an ablation).
ONE_OR_MORE = frozenset({"planner", "obs_mode", "prompt_suite"})


def recorded_options(kw: dict[str, Any]) -> dict[str, Any]:
    """The options to keep in `run.json`: JSON values, paths absolute, secrets redacted."""
    return {name: _recordable(name, value) for name, value in kw.items()
            if name not in NOT_RECORDED}


def _recordable(name: str, value: Any) -> Any:
    """`value` of option `name` as run.json keeps it (so that two spellings of one thing,
    ``./suite`` and its absolute path, compare equal)."""
    value = _json(value)
    if name in PATHS:
        value = _absolute(value)
    elif name in REFERENCES:
        value = _each(value, REFERENCES[name])
    if name in ONE_OR_MORE and isinstance(value, list) and len(value) == 1:
        value = value[0]
    return _redacted(name, value)


def restore_options(kw: dict[str, Any], recorded: dict[str, Any],
                    ctx: click.Context) -> dict[str, Any]:
    """`kw` with the recorded values of the options not given now; raise `UsageError` for a
    given option that would change what is sent or scored."""
    out = dict(kw)
    for name, value in recorded.items():
        if name not in kw:
            continue  # an option of another version of cocobench
        given = ctx.get_parameter_source(name) not in (ParameterSource.DEFAULT, None)
        if not given:
            if _redacted_value(value):
                raise click.UsageError(
                    f"--resume: the recorded {_flag(ctx, name)} carried credentials, which "
                    f"are never stored: give {_flag(ctx, name)} again")
            out[name] = _python(kw[name], value)
            continue
        now = _recordable(name, kw[name])
        if name in SHAPING and now != value:
            raise click.UsageError(
                f"--resume: {_flag(ctx, name)} {show_value(now)} differs from the recorded run "
                f"({show_value(value)}); it changes what is sent or scored, so a resumed run keeps "
                "it: run without it, or into a new --out")
    return out


def _suite_spec(text: str) -> str:
    """A prompt suite as its canonical spec (a folder's absolute path, variants sorted)."""
    from cocobench_agents.prompts import load_prompt_suite

    return load_prompt_suite(text).spec


def _planner_ref(text: str) -> str:
    """A planner reference with its file, if any, made absolute (``FILE.py:NAME``)."""
    target, sep, name = text.rpartition(":")
    if sep and (target.endswith(".py") or "/" in target) and Path(target).is_file():
        return f"{Path(target).resolve()}:{name}"
    return text


#: Options naming a prompt suite or a planner: recorded in canonical form.
REFERENCES = {"prompt_suite": _suite_spec, "planner": _planner_ref}


def _each(value: Any, canonical: Any) -> Any:
    if isinstance(value, list):
        return [canonical(v) for v in value]
    return canonical(value) if isinstance(value, str) else value


def _json(value: Any) -> Any:
    if isinstance(value, (tuple, list)):
        return [_json(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    return value


def _python(current: Any, value: Any) -> Any:
    """A recorded JSON value in the shape click gives (tuples for multiple options)."""
    if isinstance(current, tuple) and isinstance(value, str):
        return (value,)  # a repeatable option's one value (`ONE_OR_MORE`)
    return tuple(value) if isinstance(current, tuple) and isinstance(value, list) else value


def _absolute(value: Any) -> Any:
    if isinstance(value, list):
        return [_absolute(v) for v in value]
    if isinstance(value, str) and Path(value).exists():
        return str(Path(value).resolve())
    return value


def _redacted(name: str, value: Any) -> Any:
    if name == "api_base":
        return redact_url(value)
    if name == "extra_json" and value:
        try:
            return json.dumps(redact_named(json.loads(value)), sort_keys=True)
        except ValueError:
            return value  # not JSON: refused by the option's own check
    return value


def _redacted_value(value: Any) -> bool:
    return isinstance(value, str) and REDACTED in value


def _flag(ctx: click.Context, name: str) -> str:
    for param in ctx.command.params:
        if param.name == name and param.opts:
            return max(param.opts, key=len)
    return name


def show_value(value: Any) -> str:
    """`value` as short JSON, for messages."""
    text = json.dumps(value)
    return text if len(text) < 80 else text[:77] + "..."
