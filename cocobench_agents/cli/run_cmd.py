"""`cocobench run`: run planners on instances into a run folder (DESIGN §4)."""

from __future__ import annotations

import asyncio
import shlex
import sys
from typing import Any

import click

from benchmark_adapter.sim.backends import check_backend
from benchmark_adapter.tasks import select_tasks
from cocobench_agents.cli.resume import recorded_options, restore_options, show_value
from cocobench_agents.cli.run_options import (
    backend_option,
    load_source,
    missing_option,
    model_options,
    model_settings,
    selection_options,
)
from cocobench_agents.cli.run_ray import check_executor_options, executor_options, run_on_ray
from cocobench_agents.cli.tables import table
from cocobench_agents.graphs import planner_spec
from cocobench_agents.graphs.plugins import check_unchanged as check_planners_unchanged
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
from cocobench_agents.harness.infra import count_infra_failures, retry_command
from cocobench_agents.harness.limits import SpendLimit
from cocobench_agents.harness.plan import planner_conditions, suite_arms
from cocobench_agents.harness.planner_check import check_planners
from cocobench_agents.harness.store import RunFolderWriteError
from cocobench_agents.harness.summary import latest, summary_table
from cocobench_agents.models import ModelPool
from cocobench_agents.prompts import (
    DEFAULT_SUITE,
    PromptSuite,
    check_unchanged,
    load_prompt_suite,
)

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
@click.option("--planner", multiple=True, default=["centralized"], show_default=True,
              metavar="NAME|FILE.py:NAME|module:NAME",
              help="centralized, decentralized, decentralized-broadcast, leader-worker, "
                   "oracle, an installed planner (`cocobench planners`) or your own. "
                   "Repeatable: each planner is an arm (its condition, under --obs).")
@click.option("--obs", "obs_mode", type=click.Choice(["image", "blind"]), multiple=True,
              default=["image"], show_default=True,
              help="Observation mode (with --planner; repeatable: every planner under each).")
@click.option("--conditions", metavar="LIST",
              help="Instead of --planner/--obs: all, image, blind, or e.g. C0_image,D1_blind.")
@click.option("--model", "models", multiple=True, metavar="M",
              help="A LiteLLM model string or a built-in (greedy, random[:SEED], "
                   "scripted:PATH, replay:PATH). Repeatable.")
@click.option("--agent-model", "agent_models", multiple=True, metavar="AGENT=M",
              help="A different model for one agent of a decentralized team (repeatable).")
@click.option("--prompt-suite", multiple=True, default=[DEFAULT_SUITE], show_default=True,
              metavar="NAME|PATH",
              help="Prompt suite: a shipped name or a suite folder (see `cocobench prompts`), "
                   "with ablations joined by '+': cocobench-v1+no-hint. Repeatable: each "
                   "suite is an arm, crossed with models and conditions.")
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
@click.option("--max-cost", type=click.FloatRange(min=0), default=None, metavar="USD",
              help="Stop starting episodes once the run's model calls cost this much "
                   "(episodes in flight finish; --resume with a higher limit completes).")
@click.option("--max-total-tokens", type=click.IntRange(min=0), default=None, metavar="N",
              help="Stop starting episodes once the run's model calls used this many "
                   "tokens (prompt + completion).")
@click.option("--episode-timeout", type=click.FloatRange(min=0), default=7200.0,
              show_default=True, metavar="S",
              help="Wall-clock seconds an episode may run before it ends as an "
                   "infrastructure error (0: no limit).")
@click.option("--retry-errors", is_flag=True,
              help="With --resume: re-run infrastructure failures and backend errors too.")
@click.option("--no-preflight", is_flag=True,
              help="Skip the one call per remote model and input kind made before any "
                   "episode starts (it stops the run, exit 2, when the provider refuses).")
@backend_option
@executor_options
@click.option("--max-steps", type=click.IntRange(min=1), default=None,
              help="Override every instance's step budget.")
@click.option("--stable-ids", is_flag=True,
              help="Menu ids that never shift within an episode (deviation from the reference).")
@selection_options
@missing_option
@model_options
def run_command(**kw: Any) -> None:
    """Run planners on CoCoBench instances and record one trajectory and one result per
    episode. Every model × condition × instance × epoch is one episode."""
    folder = RunFolder(kw["out"])
    record = _open_folder(folder, kw["resume"])
    if record is not None and "cli_options" in record:
        kw = restore_options(kw, record["cli_options"], click.get_current_context())
    check_executor_options(kw)
    if kw["executor"] == "local":  # Ray workers check the node they run on
        check_backend(kw["backend"])
    request = _request(kw, record)
    pool = ModelPool(model_settings(kw))
    episodes = plan_episodes(request["tasks"], request["models"], request["conditions"],
                             request["epochs"], request["options"])
    todo = episodes if record is None else pending_episodes(
        episodes, folder, retry_errors=kw["retry_errors"])
    if todo:  # a finished run is only summarised: no model stack to load, no key to need
        _check_models(pool, request["models"], request["agent_models"])
        check_planners(c.planner for c in request["conditions"])  # the user's, by one episode
        if not kw["no_preflight"]:
            from cocobench_agents.models.preflight import preflight

            preflight(pool, [*request["models"], *request["agent_models"].values()],
                      {c.obs_mode for c in request["conditions"]
                       if planner_spec(c.planner).uses_models})
    if record is None:
        folder.create({**run_record(kw["out"], request, pool.settings, sys.argv),
                       "cli_options": recorded_options(kw)})
    click.echo(f"{len(episodes)} episodes ({len(episodes) - len(todo)} already done) "
               f"→ {folder.path}", err=True)
    stopped_early = None
    if todo:
        stopped_early = _execute(todo, folder, pool, kw, len(episodes))
    _summary(folder)
    if stopped_early is not None:
        raise stopped_early
    failed = count_infra_failures(latest(folder.results()))
    if failed:
        raise RunHadErrors(folder, failed)


def _execute(todo: list, folder: RunFolder, pool: ModelPool, kw: dict[str, Any],
             total: int) -> click.ClickException | None:
    """Run the pending episodes with a progress display; what stopped the run early, if
    anything (what did finish is recorded either way)."""
    progress = Progress(total, already_done=total - len(todo))
    limit = SpendLimit(kw["max_cost"], kw["max_total_tokens"], spent=latest(folder.results()))

    def on_result(record: dict[str, Any]) -> None:
        limit.add(record)
        progress.episode_done(record)

    options = {"limit": limit if limit.active else None,
               "episode_timeout_s": kw["episode_timeout"] or None}
    workers = kw["workers"] or available_cores()
    try:
        if kw["executor"] == "ray":
            run_on_ray(kw, todo, folder, pool.settings, on_result, **options)
        elif workers > 1:
            execute_in_workers(todo, folder, pool.settings, jobs=kw["jobs"], workers=workers,
                               on_result=on_result, **options)
        else:
            asyncio.run(execute_and_close(todo, folder, pool, jobs=kw["jobs"],
                                          on_result=on_result, **options))
    except WorkerError as exc:
        return click.ClickException(str(exc))
    except RunFolderWriteError as exc:
        return RunFolderFailed(folder, exc)
    except KeyboardInterrupt:
        return RunInterrupted(folder, progress.done, total)
    finally:
        progress.close()
    if progress.done < total and limit.reached():
        return SpendLimitReached(folder, limit, total - progress.done)
    return None


class SpendLimitReached(click.ClickException):
    """The run stopped starting episodes at --max-cost / --max-total-tokens."""

    exit_code = 3

    def __init__(self, folder: RunFolder, limit: SpendLimit, left: int) -> None:
        flag = "--max-cost USD" if limit.max_cost_usd is not None else "--max-total-tokens N"
        super().__init__(f"spend limit reached ({limit.describe()}): {left} episodes not "
                         f"started; raise the limit and finish the run with: cocobench run "
                         f"--out {shlex.quote(str(folder.path))} --resume {flag}")


class RunHadErrors(click.ClickException):
    """Episodes ended because of the model's infrastructure: exit 1, and say how to retry."""

    exit_code = 1

    def __init__(self, folder: RunFolder, failed: int) -> None:
        super().__init__(
            f"{failed} episode{'s' if failed != 1 else ''} ended on an infrastructure error "
            "(model backend error, timeout, unsupported input, or the harness) and count as "
            f"failures above; retry them with: {retry_command(folder.path)}")


def _open_folder(folder: RunFolder, resume: bool) -> dict[str, Any] | None:
    """Lock the run folder for this command's lifetime; the recorded run when resuming
    (with a warning for each repair or problem found in it)."""
    lock = click.get_current_context().with_resource(folder.lock())
    if lock.stale_pid:
        click.echo(f"warning: {folder.path}: taking over the lock of pid {lock.stale_pid}, "
                   "which ended without releasing it", err=True)
    record = folder.open_for_resume() if resume else None
    for warning in folder.warnings:
        click.echo(f"warning: {warning}", err=True)
    return record


class RunFolderFailed(click.ClickException):
    """The run folder could not be written (a full disk, an I/O error): the run stops."""

    def __init__(self, folder: RunFolder, error: RunFolderWriteError) -> None:
        super().__init__(f"the run stopped: {error}. What it recorded is kept and valid; "
                         "make room (or fix the folder) and finish the run with: cocobench "
                         f"run --out {shlex.quote(str(folder.path))} --resume")


class RunInterrupted(click.ClickException):
    """Ctrl-C during a run: what finished is kept; say how to finish the rest."""

    exit_code = 130

    def __init__(self, folder: RunFolder, done: int, total: int) -> None:
        super().__init__(f"interrupted: {done} of {total} episodes are recorded in "
                         f"{folder.path}; finish the run with: cocobench run --out "
                         f"{shlex.quote(str(folder.path))} --resume")


def _request(kw: dict[str, Any], record: dict[str, Any] | None) -> dict[str, Any]:
    """The run request from the options, checked against the recorded run when resuming."""
    if record is not None and "cli_options" not in record and not (
            kw["tasks"] or kw["suite"] or kw["models"]):
        kw = {**kw, **record["request"]}  # a folder of an older version: its recorded plan
    planners = [] if kw["conditions"] else _listed(kw["planner"])
    conditions = (parse_conditions(kw["conditions"]) if kw["conditions"]
                  else planner_conditions(planners, _listed(kw["obs_mode"])))
    # several --planner: each is an arm (its conditions), paired in the report
    planner_arms = [c.name for c in conditions] if len(planners) > 1 else []
    needs_model = any(planner_spec(c.planner).uses_models for c in conditions)
    models = list(kw["models"]) or ([] if needs_model else ["oracle"])
    if kw.get("baselines"):
        models, conditions = with_baselines(models, conditions)
    if needs_model and not models:
        raise click.UsageError("--model is required (e.g. --model greedy, or a LiteLLM model)")
    suites = [load_prompt_suite(spec) for spec in _listed(kw["prompt_suite"])]
    sources = list(kw["tasks"]) or [kw["suite"] or DEFAULT_TASKS]
    tasks = [t for source in sources for t in load_source(source, kw["missing"])]
    tasks = select_tasks(tasks, kw["eval_set"], only_cell=kw["only_cell"],
                         only_family=kw["only_family"], only_dim=kw["only_dim"],
                         task_ids=kw["task_id"], limit=kw["limit"] or 0)
    agent_models = _agent_models(kw["agent_models"])
    request = {
        "sources": sources, "tasks": tasks, "task_ids": [t.task_id for t in tasks],
        "models": models, "agent_models": agent_models,
        "conditions": conditions, "planner_arms": planner_arms, "epochs": kw["epochs"],
        "options": RunOptions(backend=kw["backend"], prompt_suite=suites[0].spec,
                              arms=suite_arms(suites), max_steps=kw["max_steps"],
                              stable_ids=kw["stable_ids"], agent_models=agent_models),
    }
    if record is not None:
        check_planners_unchanged([c.planner for c in conditions], record.get("planners") or {})
        _same_as_recorded(request, record)
        _check_suites_unchanged(suites, request["options"].arms, record)
    return request


def _listed(value: str | tuple[str, ...] | list[str]) -> list[str]:
    """A repeatable option's values (a string: one, as recorded by older versions)."""
    return [value] if isinstance(value, str) else list(value)


def _check_suites_unchanged(suites: list[PromptSuite], arms: dict[str, str],
                            record: dict[str, Any]) -> None:
    """Refuse a resumed run's prompt suite whose files changed since it was recorded."""
    if not arms:
        check_unchanged(suites[0], record.get("prompt_suite") or {})
        return
    recorded = {r.get("arm"): r for r in record.get("prompt_suites") or []
                if isinstance(r, dict)}
    for suite in suites:  # the arms themselves are checked with the plan
        check_unchanged(suite, recorded.get(suite.label) or {})


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
    arms = list(request["options"].arms)
    if arms or "arms" in recorded:
        current["arms"] = arms
    for key, value in current.items():
        if recorded.get(key) != value:
            raise click.UsageError(
                f"--resume: {key} differ from the recorded run ({show_value(recorded.get(key))} "
                f"recorded, {show_value(value)} asked); run with the same options or without them")


def _check_models(pool: ModelPool, models: list[str], agent_models: dict[str, str]) -> None:
    """Unknown models and missing API keys are reported before any episode starts."""
    for model in [*models, *agent_models.values()]:
        if model != "oracle":
            pool.validate(model)


def _summary(folder: RunFolder) -> None:
    headers, rows = summary_table(folder.results())
    click.echo(table(headers, rows, caption=LEGEND))
    click.echo(f"results: {folder.results_path}  (cocobench report "
               f"{folder.path} --out DIR for the paper's tables)")
