"""The options of `cocobench run` that set a field of `RunRequest`.

Each option's help text and default are its field's (one place for both); its parameter
name is the field's leaf name, so the command hands the engine what was given without a
table of names; each also reads a ``COCOBENCH_RUN_<OPTION>`` variable (`--max-steps`:
``COCOBENCH_RUN_MAX_STEPS``; several values of a repeatable option: separated by spaces).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, get_args

import click

from benchmark_adapter.vocabulary import BACKEND_NAMES, OBSERVATION_MODES
from cocobench_agents.engine.request import iter_fields
from cocobench_agents.harness.execution_settings import ExecutorName
from cocobench_agents.models.settings import TRANSPORTS
from cocobench_agents.setting_kinds import RUN_VARIABLE_PREFIX, run_variable

ENV_PREFIX = RUN_VARIABLE_PREFIX
_FIELDS = {path[-1]: info for path, info in iter_fields()}


def request_option(*flags: str, name: str, help_text: str | None = None,
                   **kwargs: Any) -> Callable:
    """A click option for the request's field `name`: its description as help (unless
    given), its default shown, and its environment variable."""
    info = _FIELDS[name]
    if "default" not in kwargs:
        default = info.get_default(call_default_factory=True)
        kwargs["default"] = tuple(default) if kwargs.get("multiple") else default
    kwargs.setdefault("show_default", kwargs["default"] not in (None, (), False))
    primary = max((f for f in flags if f.startswith("--")), key=len).split("/")[0]
    help_text = help_text or info.description or ""
    if kwargs.get("multiple"):
        help_text += " Repeatable."
    return click.option(*flags, name, help=help_text,
                        envvar=run_variable(primary),
                        show_envvar=True, **kwargs)


def source_options(command: Callable) -> Callable:
    """--task / --suite: the request's `selection.sources`."""
    for option in reversed([
        click.option("--task", "tasks", multiple=True, metavar="PATH",
                     envvar=ENV_PREFIX + "TASK", show_envvar=True,
                     help="A task config file or folder (repeatable; also a suite name)."),
        click.option("--suite", metavar="SUITE|PATH", envvar=ENV_PREFIX + "SUITE",
                     show_envvar=True,
                     help="A suite name or path (default: cocobench-240): cocobench-240, "
                          "cocobench-full, demo, an index.json or a subset file."),
    ]):
        command = option(command)
    return command


_OPTIONS = [
    request_option("--eval-set", name="eval_set", multiple=True, metavar="NAME"),
    request_option("--only-cell", name="only_cell", metavar="CELL"),
    request_option("--only-family", name="only_family", metavar="FAMILY"),
    request_option("--only-dim", name="only_dim", metavar="DIM"),
    request_option("--task-id", name="task_ids", multiple=True, metavar="ID"),
    request_option("--limit", name="limit", type=click.IntRange(min=0)),
    request_option("--missing", name="missing", type=click.Choice(["skip", "error"])),
    request_option("--planner", name="planners", multiple=True,
                   metavar="NAME|FILE.py:NAME|module:NAME"),
    request_option("--obs", name="obs_modes", multiple=True,
                   type=click.Choice(list(OBSERVATION_MODES))),
    request_option("--conditions", name="conditions", metavar="LIST", type=str),
    request_option("--model", name="models", multiple=True, metavar="M"),
    request_option("--agent-model", name="agent_models", multiple=True, metavar="AGENT=M"),
    request_option("--prompt-suite", name="prompt_suites", multiple=True, metavar="NAME|PATH"),
    request_option("--out", name="out", type=click.Path(file_okay=False), default=None,
                   metavar="DIR"),
    request_option("--jobs", "-j", name="jobs", type=click.IntRange(min=1)),
    request_option("--workers", name="workers", type=click.IntRange(min=0)),
    request_option("--epochs", name="epochs", type=click.IntRange(min=1)),
    request_option("--baselines", name="baselines", is_flag=True),
    request_option("--max-cost", name="max_cost", type=click.FloatRange(min=0), metavar="USD"),
    request_option("--max-total-tokens", name="max_total_tokens", type=click.IntRange(min=0),
                   metavar="N"),
    request_option("--episode-timeout", name="episode_timeout", type=click.FloatRange(min=0),
                   metavar="S"),
    request_option("--episode-memory", name="episode_memory",
                   type=click.FloatRange(min=0, min_open=True), metavar="MB"),
    request_option("--stall-timeout", name="stall_timeout",
                   type=click.FloatRange(min=0, min_open=True), metavar="S"),
    request_option("--preflight/--no-preflight", name="preflight"),
    request_option("--backend", name="backend", type=click.Choice(list(BACKEND_NAMES))),
    request_option("--executor", name="executor", type=click.Choice(get_args(ExecutorName))),
    request_option("--ray-address", name="ray_address", metavar="HOST:PORT"),
    request_option("--thor-gpus-per-worker", name="thor_gpus_per_worker",
                   type=click.FloatRange(min=0)),
    request_option("--ray-wait", name="ray_wait", type=click.FloatRange(min=0, min_open=True),
                   metavar="S"),
    request_option("--max-steps", name="max_steps", type=click.IntRange(min=1)),
    request_option("--stable-ids", name="stable_ids", is_flag=True),
    request_option("--api-base", name="api_base", metavar="URL"),
    request_option("--api-key-env", name="api_key_env", metavar="NAME"),
    request_option("--timeout", name="timeout_s", type=click.FloatRange(min=0.1), metavar="S"),
    request_option("--max-retries", name="max_retries", type=click.IntRange(min=0)),
    request_option("--max-concurrency", name="max_concurrency", type=click.IntRange(min=1)),
    request_option("--temperature", name="temperature", metavar="T|auto|none", type=str),
    request_option("--max-tokens", name="max_tokens", type=click.IntRange(min=1)),
    request_option("--grammar", name="grammar", is_flag=True),
    request_option("--cache", name="cache_dir", type=click.Path(file_okay=False), metavar="DIR"),
    request_option("--seed", name="seed", type=int),
    request_option("--extra", name="extra_params", metavar="JSON", type=str, default=None),
    request_option("--transport", name="transport", type=click.Choice(TRANSPORTS)),
]


def request_options(command: Callable) -> Callable:
    """Every option that sets a field of the request (and --task/--suite)."""
    for option in reversed(_OPTIONS):
        command = option(command)
    return source_options(command)
