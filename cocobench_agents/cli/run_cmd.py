"""`cocobench run`: run planners on instances into a run folder (DESIGN §4)."""

from __future__ import annotations

import asyncio
import json
import shlex
import sys
from typing import Any

import click

from benchmark_adapter.sim.backends import check_backend
from benchmark_adapter.tasks import load_tasks, select_tasks
from cocobench_agents.cli.run_options import (
    backend_option,
    model_options,
    model_settings,
    selection_options,
)
from cocobench_agents.cli.tables import table
from cocobench_agents.graphs import planner_spec
from cocobench_agents.harness import (
    Condition,
    Progress,
    RunFolder,
    RunOptions,
    WorkerError,
    available_cores,
    execute_and_close,
    execute_in_workers,
    parse_conditions,
    pending_episodes,
    plan_episodes,
    run_record,
)
from cocobench_agents.harness.summary import HEADERS, summary_rows
from cocobench_agents.models import ModelPool
from cocobench_agents.prompts import DEFAULT_SUITE, load_prompt_suite

DEFAULT_TASKS = "cocobench-240"
BASELINE_MODELS = ("greedy", "random")
LEGEND = (
    "SR: task success rate. CS: mean construct score of the scored episodes (n), CS_D1..D4 "
    "per dimension; unscored episodes are not_engaged (no evidence of the construct), "
    "low_signal (too little evidence) or na_no_actions (no step taken). legal: plans with no "
    "illegal step. errors: episodes the model's infrastructure or the harness ended.")


@click.command("run")
@click.option("--task", "tasks", multiple=True, metavar="PATH",
              help="A task config file or folder (repeatable).")
@click.option("--suite", metavar="SUITE|PATH",
              help=f"A suite name or path (default: {DEFAULT_TASKS}).")
@click.option("--planner", default="centralized", show_default=True,
              help="centralized, decentralized, decentralized-broadcast, leader-worker, oracle.")
@click.option("--obs", "obs_mode", type=click.Choice(["image", "blind"]), default="image",
              show_default=True, help="Observation mode (with --planner).")
@click.option("--conditions", metavar="LIST",
              help="Instead of --planner/--obs: all, image, blind, or e.g. C0_image,D1_blind.")
@click.option("--model", "models", multiple=True, metavar="M",
              help="A LiteLLM model string or a built-in (greedy, random[:SEED], "
                   "scripted:PATH, replay:PATH). Repeatable.")
@click.option("--agent-model", "agent_models", multiple=True, metavar="AGENT=M",
              help="A different model for one agent of a decentralized team (repeatable).")
@click.option("--prompt-suite", default=DEFAULT_SUITE, show_default=True,
              help="Prompt suite, with ablations joined by '+': cocobench-v1+no-hint.")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False),
              help="Run folder.")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=8, show_default=True,
              help="Episodes run concurrently.")
@click.option("--workers", type=click.IntRange(min=0), default=1, show_default=True,
              help="Processes sharing the --jobs (0: one per core). More than one helps "
                   "when many episodes in flight against a fast server make CPU the limit.")
@click.option("--epochs", type=click.IntRange(min=1), default=1, show_default=True,
              help="Runs of every episode (repeated samples; seeds differ per epoch).")
@click.option("--baselines", is_flag=True,
              help="Also run the reference rows on the same instances: the oracle (the upper "
                   "bound) and the greedy and random built-in models.")
@click.option("--resume", is_flag=True,
              help="Complete the missing episodes of --out (starting the run if it is new).")
@click.option("--retry-errors", is_flag=True,
              help="With --resume: re-run infrastructure failures and backend errors too.")
@backend_option
@click.option("--max-steps", type=click.IntRange(min=1), default=None,
              help="Override every instance's step budget.")
@click.option("--stable-ids", is_flag=True,
              help="Menu ids that never shift within an episode (deviation from the reference).")
@selection_options
@model_options
def run_command(**kw: Any) -> None:
    """Run planners on CoCoBench instances and record one trajectory and one result per
    episode. Every model × condition × instance × epoch is one episode."""
    check_backend(kw["backend"])
    folder = RunFolder(kw["out"])
    record = folder.open_for_resume() if kw["resume"] else None
    request = _request(kw, record)
    pool = ModelPool(model_settings(kw))
    episodes = plan_episodes(request["tasks"], request["models"], request["conditions"],
                             request["epochs"], request["options"])
    todo = episodes if record is None else pending_episodes(
        episodes, folder, retry_errors=kw["retry_errors"])
    if todo:  # a finished run is only summarised: no model stack to load, no key to need
        _check_models(pool, request["models"], request["agent_models"])
    if record is None:
        folder.create(run_record(kw["out"], request, pool.settings, sys.argv))
    click.echo(f"{len(episodes)} episodes ({len(episodes) - len(todo)} already done) "
               f"→ {folder.path}", err=True)
    stopped_early = None
    if todo:
        stopped_early = _execute(todo, folder, pool, kw, len(episodes))
    _summary(folder)
    if stopped_early is not None:
        raise stopped_early


def _execute(todo: list, folder: RunFolder, pool: ModelPool, kw: dict[str, Any],
             total: int) -> click.ClickException | None:
    """Run the pending episodes with a progress display; what stopped the run early, if
    anything (what did finish is recorded either way)."""
    progress = Progress(total, already_done=total - len(todo))
    workers = kw["workers"] or available_cores()
    try:
        if workers > 1:
            execute_in_workers(todo, folder, pool.settings, jobs=kw["jobs"], workers=workers,
                               on_result=progress.episode_done)
        else:
            asyncio.run(execute_and_close(todo, folder, pool, jobs=kw["jobs"],
                                          on_result=progress.episode_done))
    except WorkerError as exc:
        return click.ClickException(str(exc))
    except KeyboardInterrupt:
        return RunInterrupted(folder, progress.done, total)
    finally:
        progress.close()
    return None


class RunInterrupted(click.ClickException):
    """Ctrl-C during a run: what finished is kept; say how to finish the rest."""

    exit_code = 130

    def __init__(self, folder: RunFolder, done: int, total: int) -> None:
        super().__init__(f"interrupted: {done} of {total} episodes are recorded in "
                         f"{folder.path}; finish the run with: cocobench run --out "
                         f"{shlex.quote(str(folder.path))} --resume")


def _request(kw: dict[str, Any], record: dict[str, Any] | None) -> dict[str, Any]:
    """The run request from the options, checked against the recorded run when resuming."""
    if record is not None and not (kw["tasks"] or kw["suite"] or kw["models"]):
        kw = {**kw, **record["request"]}  # a bare --resume reuses the recorded request
    conditions = (parse_conditions(kw["conditions"]) if kw["conditions"]
                  else [Condition(planner_spec(kw["planner"]).name, kw["obs_mode"])])
    needs_model = any(planner_spec(c.planner).uses_models for c in conditions)
    models = list(kw["models"]) or ([] if needs_model else ["oracle"])
    if kw.get("baselines"):
        models, conditions = with_baselines(models, conditions)
    if needs_model and not models:
        raise click.UsageError("--model is required (e.g. --model greedy, or a LiteLLM model)")
    load_prompt_suite(kw["prompt_suite"])
    sources = list(kw["tasks"]) or [kw["suite"] or DEFAULT_TASKS]
    tasks = [t for source in sources for t in load_tasks(source)]
    tasks = select_tasks(tasks, kw["eval_set"], only_cell=kw["only_cell"],
                         only_family=kw["only_family"], only_dim=kw["only_dim"],
                         task_ids=kw["task_id"], limit=kw["limit"] or 0)
    agent_models = _agent_models(kw["agent_models"])
    request = {
        "sources": sources, "tasks": tasks, "task_ids": [t.task_id for t in tasks],
        "models": models, "agent_models": agent_models,
        "conditions": conditions, "epochs": kw["epochs"],
        "options": RunOptions(backend=kw["backend"], prompt_suite=kw["prompt_suite"],
                              max_steps=kw["max_steps"], stable_ids=kw["stable_ids"],
                              agent_models=agent_models),
    }
    if record is not None:
        _same_as_recorded(request, record)
    return request


def with_baselines(models: list[str], conditions: list[Condition]
                   ) -> tuple[list[str], list[Condition]]:
    """`models` and `conditions` plus the reference rows: the greedy and random built-ins
    under every condition, and the oracle (the upper bound) under each observation mode."""
    models = [*models, *(m for m in BASELINE_MODELS if m not in models)]
    oracles = [Condition("oracle", obs) for obs in dict.fromkeys(c.obs_mode for c in conditions)]
    return models, [*conditions, *(c for c in oracles if c not in conditions)]


def _agent_models(pairs: tuple[str, ...] | list[str]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        agent, sep, model = pair.partition("=")
        if not sep or not agent.strip() or not model.strip():
            raise click.BadParameter(f"{pair!r}: expected AGENT=MODEL, e.g. agent_2=gpt-4o",
                                     param_hint="--agent-model")
        out[agent.strip()] = model.strip()
    return out


def _same_as_recorded(request: dict[str, Any], record: dict[str, Any]) -> None:
    recorded = record["plan"]
    current = {"task_ids": request["task_ids"], "models": request["models"],
               "conditions": [c.name for c in request["conditions"]],
               "epochs": request["epochs"]}
    for key, value in current.items():
        if recorded.get(key) != value:
            raise click.UsageError(
                f"--resume: {key} differ from the recorded run ({_short(recorded.get(key))} "
                f"recorded, {_short(value)} asked); run with the same options or without them")


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) < 80 else text[:77] + "..."


def _check_models(pool: ModelPool, models: list[str], agent_models: dict[str, str]) -> None:
    """Unknown models and missing API keys are reported before any episode starts."""
    for model in [*models, *agent_models.values()]:
        if model != "oracle":
            pool.validate(model)


def _summary(folder: RunFolder) -> None:
    rows = summary_rows(folder.results())
    click.echo(table(HEADERS, rows, caption=LEGEND))
    click.echo(f"results: {folder.results_path}  (cocobench report "
               f"{folder.path} --out DIR for the paper's tables)")
