"""Shared options of the commands: task sources, instance selection and model settings."""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from typing import Any

import click

from benchmark_adapter.sim.backends import BACKENDS
from benchmark_adapter.tasks import MissingTasksWarning, TaskConfig, load_tasks
from cocobench_agents.models import TRANSPORTS, ModelSettings

process_jobs_option = click.option(
    "--jobs", "-j", type=click.IntRange(min=0), default=1, show_default=True,
    help="Worker processes (0 = one per core).")

backend_option = click.option(
    "--backend", type=click.Choice(sorted(BACKENDS)), default="embedded", show_default=True,
    help="Simulator: the embedded one, or real AI2-THOR (pip install 'cocobench-agents[thor]').")


missing_option = click.option(
    "--missing", type=click.Choice(["skip", "error"]), default="skip", show_default=True,
    help="Tasks an index or subset file (e.g. rep240.json) lists but whose configs are absent: "
         "skip them with a warning, as the reference's eval-set selection does, or stop.")


def load_source(source: str, missing: str) -> list[TaskConfig]:
    """The tasks of one SOURCE; skipped missing tasks are reported on stderr in one line."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MissingTasksWarning)
        tasks = load_tasks(source, missing=missing)
    for warning in caught:
        if issubclass(warning.category, MissingTasksWarning):
            click.echo(f"cocobench: warning: {warning.message}", err=True)
        else:
            warnings.showwarning(warning.message, warning.category, warning.filename,
                                 warning.lineno)
    return tasks


def selection_options(command: Callable) -> Callable:
    """--eval-set / --only-* / --task-id / --limit, as the reference's evaluate_vlm.py."""
    for option in reversed([
        click.option("--eval-set", multiple=True, metavar="NAME",
                     help="A cell, dim, family, curated set or task id (repeatable)."),
        click.option("--only-cell", default=None, metavar="CELL",
                     help="Keep only this cell (e.g. A_D1)."),
        click.option("--only-family", default=None, metavar="FAMILY",
                     help="Keep only this task family."),
        click.option("--only-dim", default=None, metavar="DIM",
                     help="Keep only this coordination dimension (D1..D4)."),
        click.option("--task-id", multiple=True, metavar="ID", help="Keep only these ids."),
        click.option("--limit", type=click.IntRange(min=0), default=0,
                     help="At most K instances (0: all)."),
    ]):
        command = option(command)
    return command


def model_options(command: Callable) -> Callable:
    """Remote model settings (LiteLLM)."""
    for option in reversed([
        click.option("--api-base", default=None, help="Endpoint URL (e.g. a local server)."),
        click.option("--api-key-env", default=None, metavar="NAME",
                     help="Name of the environment variable holding the API key."),
        click.option("--timeout", type=click.FloatRange(min=0.1), default=180.0,
                     show_default=True, help="Seconds per model call (first attempt)."),
        click.option("--max-retries", type=click.IntRange(min=0), default=2, show_default=True,
                     help="Retries on transient model errors."),
        click.option("--max-concurrency", type=click.IntRange(min=1), default=16,
                     show_default=True, help="Model calls in flight per model."),
        click.option("--temperature", type=float, default=None,
                     help="Sampling temperature (default: the reference's rule)."),
        click.option("--max-tokens", type=click.IntRange(min=1), default=None,
                     help="Completion token limit per call (default: not sent)."),
        click.option("--grammar", is_flag=True,
                     help="Constrain replies to the menu ids with a GBNF grammar "
                          "(llama.cpp servers)."),
        click.option("--cache", "cache_dir", type=click.Path(file_okay=False), default=None,
                     help="On-disk response cache folder."),
        click.option("--seed", type=int, default=None, help="Seed (random built-in, APIs)."),
        click.option("--extra", "extra_json", default=None, metavar="JSON",
                     help='Extra call parameters, e.g. \'{"top_p": 0.9}\'.'),
        click.option("--transport", type=click.Choice(TRANSPORTS), default="litellm",
                     show_default=True,
                     help="How remote models are called: LiteLLM (any provider), or http, a "
                          "lean OpenAI-compatible client for openai/NAME models (for high "
                          "--jobs against a local server; see docs/models.md)."),
    ]):
        command = option(command)
    return command


def model_settings(kw: dict[str, Any]) -> ModelSettings:
    """`ModelSettings` from the parsed options."""
    try:
        extra = json.loads(kw["extra_json"]) if kw.get("extra_json") else {}
    except json.JSONDecodeError as exc:
        raise click.BadParameter(f"not JSON: {exc}", param_hint="--extra") from None
    if not isinstance(extra, dict):
        raise click.BadParameter("must be a JSON object", param_hint="--extra")
    kwargs: dict[str, Any] = {
        "api_base": kw["api_base"], "api_key_env": kw["api_key_env"],
        "timeout_s": kw["timeout"], "max_retries": kw["max_retries"],
        "max_concurrency": kw["max_concurrency"], "max_tokens": kw["max_tokens"],
        "grammar": kw["grammar"], "cache_dir": kw["cache_dir"], "seed": kw["seed"],
        "extra_params": extra, "transport": kw["transport"],
    }
    if kw["temperature"] is not None:
        kwargs["temperature"] = kw["temperature"]
    try:
        return ModelSettings(**kwargs)
    except ValueError as exc:
        raise click.UsageError(flag_names(str(exc))) from None


#: `ModelSettings` fields as the options that set them, for messages.
FLAGS = {"api_key_env": "--api-key-env", "api_base": "--api-base", "timeout_s": "--timeout",
         "max_retries": "--max-retries", "max_concurrency": "--max-concurrency",
         "max_tokens": "--max-tokens", "extra_params": "--extra", "cache_dir": "--cache"}


def flag_names(message: str) -> str:
    """`message` with setting names replaced by the flags a user types."""
    for name, flag in FLAGS.items():
        message = message.replace(name, flag)
    return message
