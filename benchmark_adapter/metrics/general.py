"""General (construct-independent) episode metrics and distributed stats (reference §7.3)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from benchmark_adapter.vocabulary import PRECEDENCE

from .errors import TrajectoryError
from .steps import (
    AFFORDANCE_MARKERS,
    INTERACTION_SKILLS,
    Step,
    allowed_skills_by_agent,
    classify_step,
    extract_steps,
    has_marker,
    task_config,
    trajectory_items,
)


@dataclass(frozen=True)
class GeneralMetrics:
    """The reference's general metrics of one episode (names follow its keys).

    ``success`` is the raw goal check; ``success_with_d2_legality_gate`` is what
    the batch evaluator reports as ``task_success`` (False for a D2 episode whose
    plan is not legal).
    """

    success: bool
    success_with_d2_legality_gate: bool
    subgoal_success_rate: float | None
    checks: str
    legal_plan: bool | None
    n_action_steps: int
    n_agents: int
    per_agent_actions: dict[str, int]
    makespan: int
    load_imbalance: int
    wait_steps: int
    failed_steps: int
    coordination_overhead: int
    illegal_skill: int
    dependency_violations: int
    concurrency_conflicts: int
    occupancy_conflicts: int
    affordance_failures: int
    affordance_accuracy: float | None
    safety_violations: int
    invalid_action_ratio: float
    event_histogram: dict[str, int]


@dataclass(frozen=True)
class CommVolume:
    """Broadcast traffic: message count, whitespace-word tokens, messages per round."""

    messages: int
    tokens: int
    per_round: float


@dataclass(frozen=True)
class DistributedMetrics:
    """Round-level diagnostics of a distributed (round-based) episode."""

    n_rounds: int
    decision_parallelism: float
    redundant_work_rate: float
    deadlock_rate: float
    comm_volume: CommVolume
    comm_efficiency: float | None


def final_eval(traj: Mapping[str, Any]) -> Mapping[str, Any]:
    """The episode's final goal evaluation.

    Falls back to the last item's ``eval`` (which is what the recorder copies into
    ``final_eval``) for trajectories written without the top-level field.
    """
    value = traj.get("final_eval")
    if value is None:
        items = trajectory_items(traj)
        value = items[-1].get("eval") if items else None
    if not isinstance(value, Mapping):
        raise TrajectoryError("final_eval", "missing, and no item eval to fall back on")
    if "success" not in value:
        raise TrajectoryError("final_eval.success", "missing")
    return value


def _checks(traj: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    checks = final_eval(traj).get("checks") or []
    for i, check in enumerate(checks):
        if not isinstance(check, Mapping):
            raise TrajectoryError(f"final_eval.checks[{i}]", "not an object")
    return checks


def goal_success(traj: Mapping[str, Any]) -> bool:
    """Whether every goal predicate held at the end (``final_eval.success``)."""
    return bool(final_eval(traj)["success"])


def subgoal_success_rate(traj: Mapping[str, Any]) -> float | None:
    """Passed goal checks / number of checks (``task_progress``); None without checks."""
    checks = _checks(traj)
    if not checks:
        return None
    return sum(1 for c in checks if c.get("passed")) / len(checks)


def checks_summary(traj: Mapping[str, Any]) -> str:
    """Goal checks as ``"passed/total"``, e.g. ``"2/3"``."""
    checks = _checks(traj)
    return f"{sum(1 for c in checks if c.get('passed'))}/{len(checks)}"


def legal_plan_of(categories: list[str]) -> bool | None:
    """No illegal skill and no precondition violation; None when nothing was executed."""
    if not categories:
        return None  # a 0-action episode has no plan to judge
    return "illegal_skill" not in categories and "precondition_violation" not in categories


def legal_plan(traj: Mapping[str, Any]) -> bool | None:
    """:func:`legal_plan_of` for a whole trajectory."""
    allowed = allowed_skills_by_agent(task_config(traj))
    return legal_plan_of([classify_step(s, allowed) for s in extract_steps(traj)])


def d2_legality_gate(dim: str | None, success: bool, legal: bool | None) -> bool:
    """Success as the batch evaluator reports it: D2 success also needs a legal plan."""
    # legal None (no steps) also fails the gate, exactly as `not legal_plan` does.
    return success and not (dim == PRECEDENCE and not legal)


def n_agents(config: Mapping[str, Any]) -> int:
    """Team size: agents listed in the config, else ``agent_count``, else 2."""
    listed = [a for a in config.get("agents") or [] if isinstance(a, Mapping) and a.get("id")]
    return len(listed) or int(config.get("agent_count") or 2)


def per_agent_actions(steps: list[Step]) -> dict[str, int]:
    """Steps per agent, only agents that acted at least once, sorted by agent id."""
    counts: dict[str, int] = {}
    for step in steps:
        counts[step.agent] = counts.get(step.agent, 0) + 1
    return dict(sorted(counts.items()))


def _affordance_accuracy(steps: list[Step]) -> float | None:
    puts = [s for s in steps if s.skill == "Put"]
    ok = sum(1 for s in puts if s.success)
    misses = sum(1 for s in puts if has_marker(s.error, AFFORDANCE_MARKERS))
    return ok / (ok + misses) if ok + misses else None


def _safety_violations(steps: list[Step], constraints: Mapping[str, Any]) -> int:
    fragile = set(constraints.get("fragile_objects") or [])
    return sum(1 for s in steps if s.skill == "BreakObject" and s.args.get("objectId") in fragile)


def general_metrics(traj: Mapping[str, Any]) -> GeneralMetrics:
    """All general metrics of one trajectory (reference §7.3)."""
    config = task_config(traj)
    steps = extract_steps(traj)
    allowed = allowed_skills_by_agent(config)
    categories = [classify_step(s, allowed) for s in steps]
    # The reference counts only agents that acted: an idle agent is not a 0 (QUIRK).
    counts = list(per_agent_actions(steps).values()) or [0]
    failed = sum(1 for s in steps if not s.success)
    waits = categories.count("idle_wait")
    success, legal = goal_success(traj), legal_plan_of(categories)
    return GeneralMetrics(
        success=success,
        success_with_d2_legality_gate=d2_legality_gate(
            config.get("coordination_dim"), success, legal
        ),
        subgoal_success_rate=subgoal_success_rate(traj),
        checks=checks_summary(traj),
        legal_plan=legal,
        n_action_steps=len(steps),
        n_agents=n_agents(config),
        per_agent_actions=per_agent_actions(steps),
        makespan=max(counts),
        load_imbalance=max(counts) - min(counts),
        wait_steps=waits,
        failed_steps=failed,
        coordination_overhead=waits + failed,
        illegal_skill=categories.count("illegal_skill"),
        dependency_violations=categories.count("precondition_violation"),
        concurrency_conflicts=categories.count("concurrency_conflict"),
        occupancy_conflicts=categories.count("occupancy_conflict"),
        affordance_failures=categories.count("affordance_miss"),
        affordance_accuracy=_affordance_accuracy(steps),
        safety_violations=_safety_violations(steps, config.get("task_constraints") or {}),
        invalid_action_ratio=failed / len(steps) if steps else 0.0,
        event_histogram={c: categories.count(c) for c in sorted(set(categories))},
    )


def _rounds(steps: list[Step]) -> dict[Any, list[Step]]:
    rounds: dict[Any, list[Step]] = {}
    for step in steps:
        if step.round_index is not None:
            rounds.setdefault(step.round_index, []).append(step)
    return rounds


def _duplicate_targets(round_steps: list[Step]) -> int:
    # Same-round interactions on an already-targeted object are wasted work.
    targets = [s.target_id for s in round_steps if s.skill in INTERACTION_SKILLS and s.target_id]
    return len(targets) - len(set(targets))


def distributed_metrics(traj: Mapping[str, Any]) -> DistributedMetrics | None:
    """Round diagnostics; None for centralized runs (no step has a ``round_index``)."""
    steps = extract_steps(traj)
    rounds = _rounds(steps)
    if not rounds:
        return None
    allowed = allowed_skills_by_agent(task_config(traj))
    n_rounds = len(rounds)
    landed = sum(len(r) for r in rounds.values())
    messages = [s.message for s in steps if s.message]
    progress = sum(1 for s in steps if classify_step(s, allowed) == "progress")
    return DistributedMetrics(
        n_rounds=n_rounds,
        decision_parallelism=landed / n_rounds,
        redundant_work_rate=sum(map(_duplicate_targets, rounds.values())) / max(landed, 1),
        deadlock_rate=sum(1 for r in rounds.values() if not any(s.success for s in r)) / n_rounds,
        comm_volume=CommVolume(
            messages=len(messages),
            tokens=sum(len(m.split()) for m in messages),
            per_round=len(messages) / n_rounds,
        ),
        comm_efficiency=progress / len(messages) if messages else None,
    )
