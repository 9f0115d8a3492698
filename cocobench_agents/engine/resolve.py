"""From a request to the episodes it stands for: canonical references, the instances its
sources select, its conditions and arms, the baselines.

Loading is checked here (unusable configs, unknown conditions, colliding arms: each a user
error naming the file or the setting), before anything is written.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmark_adapter.tasks import MissingTasksWarning, TaskConfig, load_tasks, select_tasks
from benchmark_adapter.vocabulary import DEFAULT_TASKS
from cocobench_agents.engine.errors import RequestError
from cocobench_agents.engine.request import RunRequest
from cocobench_agents.graphs import NO_MODEL, ORACLE, planner_spec
from cocobench_agents.harness.episodes import (
    SHORTCUTS,
    Condition,
    PlannedEpisode,
    parse_conditions,
    plan_episodes,
    planner_conditions,
    suite_arms,
)
from cocobench_agents.prompts import (
    PromptSuite,
    load_prompt_suite,
    merged_templates,
    suite_spec,
)

BASELINE_MODELS = ("greedy", "random")


@dataclass(frozen=True)
class ResolvedRun:
    """What a request resolved to: its instances, models (with baselines), conditions,
    arms, and the episodes they make."""

    request: RunRequest
    tasks: list[TaskConfig]
    models: list[str]
    conditions: list[Condition]
    planner_arms: list[str]
    suites: list[PromptSuite]
    arms: dict[str, str]  # prompt-suite arms (label → suite spec); none for one suite
    episodes: list[PlannedEpisode]

    @property
    def remote_model_modes(self) -> set[str]:
        """Observation modes under which some condition calls the models."""
        return {c.obs_mode for c in self.conditions if planner_spec(c.planner).uses_models}

    @property
    def called_models(self) -> list[str]:
        """Every model a seat of the run may call (the built-ins among them): the models and
        agent models it names, less the label of a planner's rows that call none."""
        return [m for m in [*self.models, *self.request.agent_models.values()]
                if m != NO_MODEL]

    def plan_record(self) -> dict[str, Any]:
        """`run.json`'s ``plan``: what the request resolved to (the reports count planned
        episodes from it, and a resume checks that the sources still select the same)."""
        return {"task_ids": [t.task_id for t in self.tasks], "models": self.models,
                "conditions": [c.name for c in self.conditions],
                **({"arms": list(self.arms)} if self.arms else {}),
                **({"planner_arms": self.planner_arms} if self.planner_arms else {})}


def canonical(request: RunRequest) -> RunRequest:
    """`request` with every reference in one spelling, so that two spellings of one run
    compare equal: paths absolute, prompt suites as their canonical spec, planner files
    absolute, condition shortcuts expanded."""
    selection = request.selection.model_copy(
        update={"sources": [_absolute(s) for s in request.selection.sources]})
    settings = request.model_settings
    if settings.cache_dir is not None:
        settings = settings.model_copy(update={"cache_dir": settings.cache_dir.resolve()})
    conditions = None if request.conditions is None else list(dict.fromkeys(
        _planner_ref(name) for part in request.conditions
        for name in SHORTCUTS.get(part, [part])))
    return request.model_copy(update={
        "out": request.out.resolve(), "selection": selection, "model_settings": settings,
        "prompt_suites": list(dict.fromkeys(suite_spec(s) for s in request.prompt_suites)),
        "planners": [_planner_ref(p) for p in request.planners], "conditions": conditions})


def resolve(request: RunRequest, notify: Callable[[str], None]) -> ResolvedRun:
    """The episodes of a canonical `request` (`notify` hears about skipped missing tasks)."""
    planners = [] if request.conditions else request.planners
    conditions = (parse_conditions(",".join(request.conditions)) if request.conditions
                  else planner_conditions(planners, request.obs_modes))
    # several planners: each is an arm (its conditions), paired in the report
    planner_arms = [c.name for c in conditions] if len(planners) > 1 else []
    needs_model = any(planner_spec(c.planner).uses_models for c in conditions)
    models = list(request.models) or ([] if needs_model else [NO_MODEL])
    if request.baselines:
        models, conditions = with_baselines(models, conditions)
    if needs_model and not models:
        raise RequestError("no model given: --model is required (e.g. --model greedy, or a "
                           "LiteLLM model)")
    # with the planners' own templates: run.json's hash of a suite covers them
    templates = merged_templates({c.planner: planner_spec(c.planner).templates
                                  for c in conditions})
    suites = [load_prompt_suite(spec, templates) for spec in request.prompt_suites]
    selection = request.selection
    tasks = [t for source in selection.sources
             for t in load_source(source, selection.missing, notify)]
    tasks = select_tasks(tasks, selection.eval_set, only_cell=selection.only_cell,
                         only_family=selection.only_family, only_dim=selection.only_dim,
                         task_ids=selection.task_ids, limit=selection.limit)
    unknown = unknown_seats(request.agent_models, tasks)
    if unknown:
        raise RequestError(f"--agent-model {unknown}")
    arms = suite_arms(suites)
    episodes = plan_episodes(tasks, models, conditions, request.epochs, arms=arms,
                             agent_models=request.agent_models, backend=request.backend,
                             prompt_suite=suites[0].spec, max_steps=request.max_steps,
                             stable_ids=request.stable_ids)
    return ResolvedRun(request, tasks, models, conditions, planner_arms, suites, arms,
                       episodes)


def unknown_seats(names: Any, tasks: list[TaskConfig]) -> str | None:
    """What is wrong with the seats `names` (an agent-model mapping's keys, Inspect's model
    roles) when one names no agent of the instances `tasks` (a misspelt seat would be
    ignored: its agent would decide with the team's model); None when every one does."""
    agents = sorted({agent for task in tasks for agent in task.agent_ids})
    unknown = [name for name in names if name not in agents]
    if not unknown:
        return None
    return (f"{', '.join(unknown)}: no agent of the selected instances is named so (their "
            f"agents: {', '.join(agents)})")


def with_baselines(models: list[str], conditions: list[Condition]
                   ) -> tuple[list[str], list[Condition]]:
    """`models` and `conditions` plus the reference rows: the greedy and random built-ins
    under every condition, and the oracle (the upper bound) under each observation mode."""
    models = [*models, *(m for m in BASELINE_MODELS if m not in models)]
    oracles = [Condition(ORACLE, obs) for obs in dict.fromkeys(c.obs_mode for c in conditions)]
    return models, [*conditions, *(c for c in oracles if c not in conditions)]


class UnknownTask(RequestError):
    """A task that is neither a task-config file of one instance nor an instance of its
    source."""


def find_task(task: str, source: str = DEFAULT_TASKS) -> TaskConfig:
    """The instance `task` names: a task-config file (of one instance), or an instance id of
    `source` (`cocobench prompts show --task`, the `episode` graph's ``task``)."""
    if Path(task).is_file():
        configs = load_tasks(task)
        if len(configs) != 1:
            raise UnknownTask(f"{task} holds {len(configs)} instances; pass --source {task} "
                              "--task ID")
        return configs[0]
    configs = load_tasks(source)
    for config in configs:
        if config.task_id == task:
            return config
    examples = ", ".join(c.task_id for c in configs[:2])
    raise UnknownTask(f"unknown task {task!r}: no instance {task!r} in {source} (neither a "
                      f"task-config file; ids look like {examples}; see `cocobench list "
                      f"{source}`)")


def load_source(source: str, missing: str, notify: Callable[[str], None]) -> list[TaskConfig]:
    """The tasks of one source; tasks it lists but whose configs are absent are told to
    `notify` in one line (with ``missing="skip"``)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MissingTasksWarning)
        tasks = load_tasks(source, missing=missing)
    for warning in caught:
        if issubclass(warning.category, MissingTasksWarning):
            notify(str(warning.message))
        else:
            warnings.showwarning(warning.message, warning.category, warning.filename,
                                 warning.lineno)
    return tasks


def _absolute(source: str) -> str:
    path = Path(source)
    return str(path.resolve()) if path.exists() else source


def _planner_ref(text: str) -> str:
    """A planner reference (or a condition naming one, ``FILE.py:NAME_image``) with its
    file, if any, made absolute."""
    target, sep, name = text.rpartition(":")
    if sep and (target.endswith(".py") or "/" in target) and Path(target).is_file():
        return f"{Path(target).resolve()}:{name}"
    return text
