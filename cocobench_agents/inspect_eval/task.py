"""The Inspect task `cocobench`: one sample per instance × condition (× prompt-suite arm);
Inspect's epochs are the episodes' epochs."""

from __future__ import annotations

import functools
import itertools
import logging
from typing import Any

from inspect_ai import Task, task
from inspect_ai.dataset import MemoryDataset, Sample
from inspect_ai.model import GenerateConfig

from cocobench_agents.engine.errors import is_user_error
from cocobench_agents.engine.resolve import canonical, resolve
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.prompts import DEFAULT_SUITE, suite_label

from .params import TaskParameterError, task_request
from .preflight import PreflightFailed, check_eval_models, check_roles, sampling_notice
from .scorer import cocobench_scorer, findable_by_its_logged_name
from .solver import cocobench_solver

findable_by_its_logged_name()  # `inspect score LOG` as Inspect users type it

logger = logging.getLogger(__name__)
REQUEST = "cocobench_request"  # the task metadata's key of the request
#: The task's version (Inspect's `Task.version`; as in the inspect_evals register entry).
VERSION = "1-A"


@task
def cocobench(task: str | list[str] | None = None, suite: str | list[str] | None = None,
              conditions: str | list[str] | None = None,
              planner: str | list[str] | None = None, obs: str | list[str] | None = None,
              prompt_suite: str | list[str] | None = None, max_steps: int | None = None,
              backend: str | None = None, **options: Any) -> Task:
    """CoCoBench episodes decided by Inspect's model (docs/inspect.md).

    Args:
        task: The instances' source, as `cocobench run --task`: a suite name (cocobench-240,
            cocobench-full, demo), task-config files or folders, an index or subset file.
        suite: Another name of `task`.
        conditions: Conditions such as ``C0_image,D1_blind``, or all, image, blind.
        planner: Planners (instead of `conditions`), each under the modes of `obs`.
        obs: Observation modes of `planner` (image, blind).
        prompt_suite: Prompt suites; several are arms crossed with the conditions.
        max_steps: Override every instance's step budget.
        backend: Simulator: embedded (default) or ai2thor.
        **options: Any other option of `cocobench run`, by its name (``task_id``,
            ``only_dim``, ``limit``, ``stable_ids``, ``temperature``, ``seed``, …).
    """
    params = {"task": task, "suite": suite, "conditions": conditions, "planner": planner,
              "obs": obs, "prompt_suite": prompt_suite, "max_steps": max_steps,
              "backend": backend, **options}
    try:
        request = canonical(task_request(params))
        run = resolve(request, notify=lambda _: None)
    except Exception as exc:
        if not is_user_error(exc):
            raise
        raise TaskParameterError(f"CoCoBench task parameters: {exc}") from None
    if not run.episodes:
        raise TaskParameterError("CoCoBench task parameters: they select no instance")
    try:
        check_roles(run.tasks)
        if request.preflight:
            check_eval_models(request.model_settings, run.episodes)
    except PreflightFailed as exc:
        raise TaskParameterError(str(exc)) from None
    notice = sampling_notice(request.model_settings, run.episodes)
    if notice:
        logger.warning(notice)
    planned = {sample_id(p): p for p in spread(run.episodes)}
    return Task(
        dataset=MemoryDataset([_sample(key, p) for key, p in planned.items()],
                              name="cocobench"),
        solver=cocobench_solver(planned, request.model_settings),
        scorer=cocobench_scorer(),
        config=bounded_retries(request.model_settings),
        version=VERSION,
        # what `cocobench import-inspect` makes the log's run folder from
        metadata={REQUEST: request.model_dump(mode="json", exclude={"out", "models"})},
    )


def bounded_retries(settings: Any) -> GenerateConfig:
    """`cocobench run`'s retry policy as the task's defaults (Inspect's own retry a failing
    call without end): its retries, and its first attempt's timeout for each attempt.
    ``--max-retries``, ``--attempt-timeout`` and ``--timeout`` override them."""
    return GenerateConfig(max_retries=settings.max_retries,
                          attempt_timeout=int(settings.timeout_s))


def spread(episodes: list[PlannedEpisode]) -> list[PlannedEpisode]:
    """The episodes taken in turn from each condition × arm: each one's first instance, then
    each one's second, … . Inspect's ``--limit N`` runs the first N samples: in the plan's
    order (condition, then arm, then instance) they were the first condition's and arm's
    only. The order changes no sample id."""
    cells: dict[tuple[str, str], list[PlannedEpisode]] = {}
    for episode in episodes:
        cells.setdefault((episode.key.condition, episode.key.arm), []).append(episode)
    return [episode for turn in itertools.zip_longest(*cells.values()) for episode in turn
            if episode is not None]


def sample_id(planned: PlannedEpisode) -> str:
    """A sample's id: its condition, prompt suite and instance
    (``C0_image/A_D1__FloorPlan1__seed0``; ``C0_image/mine/A_D1__…`` under the suite
    ``mine``). The default suite adds no part, alone or beside other arms, so that a
    sample keeps its id when arms are added (its log can be retried or compared)."""
    key = planned.key
    return "/".join(part for part in (key.condition, _suite_part(planned.spec.prompt_suite),
                                      key.task_id) if part)


@functools.cache
def _suite_part(spec: str) -> str:
    """The id part of the prompt suite `spec`: its label (the arm's), none for the default."""
    return "" if spec == DEFAULT_SUITE else suite_label(spec)


def _sample(sid: str, planned: PlannedEpisode) -> Sample:
    spec, key = planned.spec, planned.key
    config = spec.config
    return Sample(
        id=sid,
        input=(f"CoCoBench episode {config.task_id} under {key.condition}: the planner "
               f"{spec.planner} decides for {', '.join(config.agent_ids)} with the model."),
        metadata={"task_id": config.task_id, "condition": key.condition, "arm": key.arm,
                  "planner": spec.planner, "obs_mode": spec.obs_mode,
                  "prompt_suite": spec.prompt_suite, "cell": config.cell,
                  "dim": config.coordination_dim, "family": config.task_family},
    )
