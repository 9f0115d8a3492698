"""How an episode ended: terminal reason, planner stats, failure taxonomy (reference §7.5)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .errors import TrajectoryError
from .general import goal_success
from .steps import trajectory_items

#: Episode-level outcome classes, in the order reports list them.
FAILURE_KINDS: tuple[str, ...] = (
    "success",
    "protocol_failure",
    "budget_exhaustion",
    "backend_error",
    "empty_plan",
    "all_idle",
    "no_actions",
    "other",
)
# Terminal reasons recorded by the policies/harness -> failure kind of a failed episode.
_KIND_BY_REASON: dict[str, str] = {
    "parse_error": "protocol_failure",
    "invalid_action_id": "protocol_failure",
    "max_steps": "budget_exhaustion",
    "backend_error": "backend_error",
    "done": "empty_plan",  # the planner declared DONE but the goals do not hold
    "all_idle": "all_idle",
    "no_actions": "no_actions",
}
PROTOCOL_STATUSES = frozenset({"parse_error", "invalid_action_id"})


@dataclass(frozen=True)
class PlannerStats:
    """The batch evaluator's per-episode planner counters."""

    planner_steps: int
    parse_errors: int
    backend_errors: int
    planner_output_error: int
    empty_plan: int


def policy_decisions(traj: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """Every recorded ``policy_decision`` (on steps and on ``policy_stop`` items), in order."""
    return [
        item["policy_decision"]
        for item in trajectory_items(traj)
        if isinstance(item.get("policy_decision"), Mapping)
    ]


def terminal_reason(traj: Mapping[str, Any]) -> str | None:
    """The last recorded ``terminal_reason``; None if no decision recorded one."""
    for decision in reversed(policy_decisions(traj)):
        if decision.get("terminal_reason"):
            return str(decision["terminal_reason"])
    return None


def _planner_steps(traj: Mapping[str, Any]) -> int:
    # The counter is cumulative, so its maximum is the number of planner calls.
    best = 0
    for i, item in enumerate(trajectory_items(traj)):
        decision = item.get("policy_decision")
        if not isinstance(decision, Mapping):
            continue
        try:
            best = max(best, int(decision.get("planner_steps") or 0))
        except (TypeError, ValueError):
            raise TrajectoryError(
                f"trajectory[{i}].policy_decision.planner_steps", "not an integer"
            ) from None
    return best


def planner_stats(traj: Mapping[str, Any], success: bool | None = None) -> PlannerStats:
    """Planner counters; ``success`` defaults to the raw goal check (as the reference).

    ``empty_plan`` is 1 when the planner said DONE but the task failed.
    """
    if success is None:
        success = goal_success(traj)
    decisions = policy_decisions(traj)
    parse_errors = sum(1 for d in decisions if d.get("status") in PROTOCOL_STATUSES)
    backend_errors = sum(1 for d in decisions if d.get("status") == "backend_error")
    return PlannerStats(
        planner_steps=_planner_steps(traj),
        parse_errors=parse_errors,
        backend_errors=backend_errors,
        planner_output_error=parse_errors + backend_errors,
        empty_plan=int(terminal_reason(traj) == "done" and not success),
    )


def failure_kind(traj: Mapping[str, Any], success: bool | None = None) -> str | None:
    """Outcome class of an episode: ``success`` or the kind of failure.

    A successful episode is ``success`` whatever stopped it (e.g. the budget ran
    out right after the last goal was met). A failed one is classified by its
    terminal reason; an unrecognised reason is ``other``, and a failed episode
    with no terminal reason at all (oracle runs, truncated files) is None.
    ``success`` defaults to the raw goal check, consistent with ``empty_plan``.
    """
    if success is None:
        success = goal_success(traj)
    if success:
        return "success"
    reason = terminal_reason(traj)
    if reason is None:
        return None
    return _KIND_BY_REASON.get(reason, "other")
