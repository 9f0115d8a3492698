"""`cocobench prompts`: list, export and preview prompt suites (docs/prompts.md).

Nothing here calls a model: `show` renders the first prompt through the planners' own code
path (`EpisodeTools`) on the embedded simulator, without importing LiteLLM or LangGraph.
"""

from __future__ import annotations

from pathlib import Path

import click

from benchmark_adapter.episode import Episode
from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.vocabulary import DEFAULT_TASKS, IMAGE, OBSERVATION_MODES
from cocobench_agents.cli.tables import table
from cocobench_agents.engine.resolve import UnknownTask, find_task
from cocobench_agents.graphs import DEFAULT_PLANNER, PLANNERS, PlannerSpec, planner_spec
from cocobench_agents.graphs.registry import AGENT_SEAT, LEADER_SEAT, LED_ROUND
from cocobench_agents.prompts import (
    DEFAULT_SUITE,
    VARIANTS,
    PromptSuite,
    PromptSuiteError,
    available_suites,
    load_prompt_suite,
    merged_templates,
    shipped_suite_files,
)
from cocobench_agents.tools import EpisodeTools

#: The built-in planners that call a model, so have a first prompt to show.
WITH_PROMPTS = [name for name, spec in PLANNERS.items() if spec.uses_models]


@click.group("prompts")
def prompts_command() -> None:
    """List, export and preview prompt suites."""


@prompts_command.command("list")
def list_command() -> None:
    """The shipped prompt suites and the variants any suite takes."""
    rows = []
    for name in available_suites():
        suite = load_prompt_suite(name)
        rows.append([name, suite.version, suite.content_hash[:12],
                     str(suite.settings.get("description", ""))])
    click.echo(table(["suite", "version", "hash", "description"], rows))
    click.echo(table(["variant (+NAME)", "effect"], [[k, v] for k, v in VARIANTS.items()]))


@prompts_command.command("export")
@click.argument("name")
@click.argument("directory", type=click.Path(path_type=Path))
@click.option("--planner", "planners", multiple=True, metavar="REF",
              help="Also write this planner's own templates (NAME.txt each; repeatable): an "
                   "installed planner, FILE.py:NAME or module:NAME.")
def export_command(name: str, directory: Path, planners: tuple[str, ...]) -> None:
    """Write the shipped suite NAME into DIRECTORY (new or empty) as a starting point; run it
    with --prompt-suite DIRECTORY."""
    files = shipped_suite_files(name)
    own = merged_templates({ref: planner_spec(ref).templates for ref in planners})
    files.update({f"{template}.txt": text.encode("utf-8") for template, text in own.items()})
    if directory.exists() and (not directory.is_dir() or any(directory.iterdir())):
        raise PromptSuiteError(f"{directory}: exists and is not an empty folder; export into "
                               f"a new or empty one")
    try:
        directory.mkdir(parents=True, exist_ok=True)
        for file_name, data in sorted(files.items()):
            (directory / file_name).write_bytes(data)
    except OSError as exc:
        raise PromptSuiteError(f"{directory}: cannot write: {exc.strerror or exc}") from None
    planner_option = "".join(f" --planner {ref}" for ref in planners)
    click.echo(f"wrote {len(files)} files of {name} to {directory}; edit them, preview with "
               f"`cocobench prompts show --suite {directory} --task ID{planner_option}`, run "
               f"with --prompt-suite {directory}")


@prompts_command.command("show")
@click.option("--suite", "--prompt-suite", "suite_spec", default=DEFAULT_SUITE,
              show_default=True, metavar="NAME|PATH",
              help="Prompt suite with optional variants: cocobench-v1+no-hint, ./my-suite.")
@click.option("--task", required=True, metavar="ID|PATH",
              help="A task config file, or an instance id of --source.")
@click.option("--source", default=DEFAULT_TASKS, show_default=True, metavar="SUITE|PATH",
              help="Where --task ID is looked up: a task suite name, file or folder.")
@click.option("--planner", default=DEFAULT_PLANNER, show_default=True,
              help=f"One of: {', '.join(WITH_PROMPTS)}; or an installed planner, "
                   "FILE.py:NAME or module:NAME.")
@click.option("--agent", default=None,
              help="The agent whose prompt to show (decentralized planners; default: the "
                   "first).")
@click.option("--obs", "obs_mode", type=click.Choice(list(OBSERVATION_MODES)), default=IMAGE,
              show_default=True, help="Observation mode.")
@click.option("--template", default=None, metavar="NAME",
              help="One of the planner's own templates (what its `ask` renders), its "
                   "strategy's fields shown as {name}.")
def show_command(suite_spec: str, task: str, source: str, planner: str, agent: str | None,
                 obs_mode: str, template: str | None) -> None:
    """Print the prompt a model gets at the first step (stdout), and what it is (stderr)."""
    spec = planner_spec(planner)
    suite = load_prompt_suite(suite_spec, spec.templates)
    seat = _first_seat(spec, agent)
    if template is not None and template not in spec.templates:
        raise click.BadParameter(f"{spec.name!r} has no template {template!r} (its own: "
                                 f"{', '.join(spec.templates) or 'none'})",
                                 param_hint="--template")
    config = _task(task, source)
    if seat == AGENT_SEAT:
        agent = agent or config.agent_ids[0]
        if agent not in config.agent_ids:
            raise click.BadParameter(f"{agent!r} is not an agent of {config.task_id} "
                                     f"({', '.join(config.agent_ids)})", param_hint="--agent")
    tools = EpisodeTools(Episode(config), suite, obs_mode=obs_mode)
    tools.start()
    if template is not None:  # asked of the first seat's agent (the team's, for a leader)
        text, _ = tools.ask_prompt(agent, template, {}, (), with_images=False,
                                   placeholders=True)
    elif seat == LEADER_SEAT:
        text, _ = tools.leader_prompt([], with_images=False)
    else:
        text, _, _ = tools.prompt(agent, [], broadcast=spec.broadcast, with_images=False)
    click.echo(_caption(suite, config, planner, agent, obs_mode, template), err=True)
    click.echo(text)


def _first_seat(spec: PlannerSpec, agent: str | None) -> str:
    """Whose prompt the planner's first decision renders, as its spec declares it: the
    leader's (a led round), the team's or an agent's (its prompt kind)."""
    if not spec.uses_models:
        raise click.BadParameter(f"{spec.name!r} has no prompt to show (planners with "
                                 f"prompts: {', '.join(WITH_PROMPTS)})", param_hint="--planner")
    seat = LEADER_SEAT if spec.loop_kind == LED_ROUND else spec.prompt_kind
    if agent is not None and seat != AGENT_SEAT:
        raise click.BadParameter(f"the {spec.name} planner's first prompt is the {seat}'s, "
                                 "not an agent's", param_hint="--agent")
    return seat


def _task(task: str, source: str) -> TaskConfig:
    """The config file `task`, or the instance `task` of `source`."""
    try:
        return find_task(task, source)
    except UnknownTask as exc:
        raise click.BadParameter(str(exc), param_hint="--task") from None


def _caption(suite: PromptSuite, config: TaskConfig, planner: str, agent: str | None,
             obs_mode: str, template: str | None) -> str:
    who = f"agent={agent}" if agent else "team"
    images = ""
    if obs_mode == IMAGE:
        view = "its own view" if agent else "the agents' views side by side"
        images = f"; the model also gets {view} as an image"
    kind = f"{template} template (its strategy's fields as {{name}})" if template else "prompt"
    return (f"# step 0 {kind} · suite {suite.spec} (hash {suite.content_hash[:12]}) · "
            f"{config.task_id} · {planner} · {who} · obs={obs_mode}{images}")
