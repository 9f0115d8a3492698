"""``EpisodeResult``: everything the metrics say about one episode, as one record."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict

from .constructs import ConstructScore, construct_score, cross_construct_scores
from .errors import TrajectoryError
from .failures import failure_kind, planner_stats, terminal_reason
from .general import DistributedMetrics, GeneralMetrics, distributed_metrics, general_metrics
from .steps import step_taxonomy, steps_parsed_once, task_config
from .usage import ModelUsage, model_usage

if TYPE_CHECKING:
    from ..tasks import TaskConfig

#: Identifiers the caller supplies (everything else comes from the trajectory).
RUN_IDENTIFIERS: frozenset[str] = frozenset(
    {"backend", "models", "planner", "obs_mode", "prompt_suite", "condition", "epoch",
     "elapsed_s", "trajectory"}
)


class EpisodeResult(BaseModel):
    """One scored episode: identifiers, the reference's flat per-episode keys, details.

    Flat keys mirror the reference's ``episode_result.json`` (``task_success`` is
    0/1 after the D2 legality gate, ``legal_plan`` 0/1/None). Nested blocks hold
    the full step taxonomy, general and distributed metrics and all four
    construct scores. ``model_dump_json()`` is deterministic for a given input.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    schema_version: int = 1
    # identifiers
    task_id: str
    cell: str | None = None
    family: str | None = None
    dim: str | None = None
    agent_count: int | None = None
    scene: str | None = None
    backend: str | None = None
    models: dict[str, str] | str | None = None
    planner: str | None = None
    obs_mode: str | None = None
    prompt_suite: str | None = None
    condition: str | None = None  # e.g. C0_image
    epoch: int | None = None
    elapsed_s: float | None = None  # wall time of the episode
    trajectory: str | None = None  # path of the trajectory file, relative to the run folder
    # the reference's flat per-episode keys
    task_success: int
    task_progress: float | None
    checks: str
    legal_plan: int | None
    construct_score: float | None
    construct_status: str
    construct_sample: int
    num_steps: int
    num_invalid_actions: int
    num_invalid_action_ratio: float
    failed_steps: int
    dependency_violations: int
    occupancy_conflicts: int
    affordance_failures: int
    illegal_skill: int
    terminal_reason: str | None
    failure_kind: str | None
    planner_steps: int
    parse_errors: int
    backend_errors: int
    planner_output_error: int
    empty_plan: int
    # details
    taxonomy: dict[str, int]
    general: GeneralMetrics
    distributed: DistributedMetrics | None
    cross_construct: dict[str, ConstructScore]
    usage: ModelUsage | None = None


def _trajectory_identifiers(traj: Mapping[str, Any]) -> dict[str, Any]:
    config = task_config(traj)
    task_id = traj.get("task_id") or config.get("task_id")
    if not task_id:
        raise TrajectoryError("task_id", "missing (neither top level nor task_config)")
    family, dim = config.get("task_family"), config.get("coordination_dim")
    agents = config.get("agents") or []
    return {
        "task_id": str(task_id),
        "cell": f"{family}_{dim}" if family and dim else None,
        "family": family,
        "dim": dim,
        "agent_count": config.get("agent_count") or (len(agents) or None),
        "scene": config.get("scene_id"),
    }


def _check_identifiers(identifiers: Mapping[str, Any]) -> None:
    unknown = sorted(set(identifiers) - RUN_IDENTIFIERS)
    if unknown:
        # Trajectory-derived identifiers may not be overridden: they must match the scores.
        raise TypeError(
            f"unknown or trajectory-derived identifiers: {', '.join(unknown)}; "
            f"accepted: {', '.join(sorted(RUN_IDENTIFIERS))}"
        )


def unrun_result(config: TaskConfig, **identifiers: Any) -> dict[str, Any]:
    """The flat result of an episode that could not run (the harness failed, it timed out):
    a failure, as the reference scores ``runner_failed`` / ``timeout`` (``task_success`` 0,
    ``legal_plan`` 0), with the task's identifiers and the run's (`RUN_IDENTIFIERS`)."""
    _check_identifiers(identifiers)
    return {"task_success": 0, "legal_plan": 0, "cell": config.cell,
            "family": config.task_family, "dim": config.coordination_dim,
            "agent_count": config.agent_count, **identifiers}


def score_trajectory(traj: Mapping[str, Any], **identifiers: Any) -> EpisodeResult:
    """Score one trajectory dict into an :class:`EpisodeResult`.

    ``identifiers`` are the run's own labels (``backend``, ``models``, ``planner``,
    ``obs_mode``, ``prompt_suite``); task identifiers come from the trajectory.
    Raises :class:`TrajectoryError` when a needed field is missing.
    """
    _check_identifiers(identifiers)
    with steps_parsed_once():
        return _score(traj, identifiers)


def _score(traj: Mapping[str, Any], identifiers: Mapping[str, Any]) -> EpisodeResult:
    general = general_metrics(traj)
    own = construct_score(traj)
    stats = planner_stats(traj, general.success)  # raw goal success, as the reference
    return EpisodeResult(
        **_trajectory_identifiers(traj),
        **identifiers,
        task_success=int(general.success_with_d2_legality_gate),
        task_progress=general.subgoal_success_rate,
        checks=general.checks,
        legal_plan=None if general.legal_plan is None else int(general.legal_plan),
        construct_score=own.score,
        construct_status=own.status,
        construct_sample=own.sample,
        num_steps=general.n_action_steps,
        num_invalid_actions=general.failed_steps,
        num_invalid_action_ratio=general.invalid_action_ratio,
        failed_steps=general.failed_steps,
        dependency_violations=general.dependency_violations,
        occupancy_conflicts=general.occupancy_conflicts,
        affordance_failures=general.affordance_failures,
        illegal_skill=general.illegal_skill,
        terminal_reason=terminal_reason(traj),
        failure_kind=failure_kind(traj, general.success),
        planner_steps=stats.planner_steps,
        parse_errors=stats.parse_errors,
        backend_errors=stats.backend_errors,
        planner_output_error=stats.planner_output_error,
        empty_plan=stats.empty_plan,
        taxonomy=step_taxonomy(traj),
        general=general,
        distributed=distributed_metrics(traj),
        cross_construct=cross_construct_scores(traj),
        usage=model_usage(traj),
    )
