"""Terminal reason, planner stats and the episode failure taxonomy (reference §7.5)."""

from __future__ import annotations

import pytest

from benchmark_adapter.metrics import (
    FAILURE_KINDS,
    PlannerStats,
    TrajectoryError,
    failure_kind,
    planner_stats,
    policy_decisions,
    score_trajectory,
    terminal_reason,
)

from .builders import BOX, KEYCHAIN, illegal_success, make_config, make_traj, step, stop


def decided(status: str, planner_steps, **fields) -> dict:
    return {
        "policy": "centralized_vlm",
        "status": status,
        "planner_steps": planner_steps,
        "terminal_reason": None,
        **fields,
    }


def episode(reason: str | None, success: bool = False, **stop_fields) -> dict:
    items = [
        step("agent_1", "Find", BOX, decision=decided("action", 1)),
        step("agent_2", "PickUp", KEYCHAIN, decision=decided("action", 2)),
    ]
    if reason is not None:
        items.append(stop(reason, **stop_fields))
    return make_traj(make_config(), items, success=success, passed=int(success), total=1)


@pytest.mark.parametrize(
    ("reason", "kind"),
    [
        ("parse_error", "protocol_failure"),
        ("invalid_action_id", "protocol_failure"),
        ("max_steps", "budget_exhaustion"),
        ("backend_error", "backend_error"),
        ("done", "empty_plan"),
        ("all_idle", "all_idle"),
        ("no_actions", "no_actions"),
        ("something_new", "other"),
    ],
)
def test_failure_kind_of_a_failed_episode(reason, kind):
    traj = episode(reason)
    assert terminal_reason(traj) == reason
    assert failure_kind(traj) == kind
    assert kind in FAILURE_KINDS


@pytest.mark.parametrize("reason", ["max_steps", "done", None])
def test_success_wins_over_the_terminal_reason(reason):
    # e.g. the budget ran out on the very step that met the last goal
    assert failure_kind(episode(reason, success=True)) == "success"


def test_failed_episode_without_terminal_reason_is_unclassified():
    traj = episode(None)
    assert terminal_reason(traj) is None
    assert failure_kind(traj) is None


def test_terminal_reason_is_the_last_one_recorded():
    traj = episode("max_steps", policy="harness")
    # an earlier decision that also carried a reason does not win
    traj["trajectory"][1]["policy_decision"]["terminal_reason"] = "parse_error"
    assert terminal_reason(traj) == "max_steps"
    assert len(policy_decisions(traj)) == 3  # two step decisions + the stop


def test_success_can_be_overridden():
    traj = episode("done", success=True)
    assert failure_kind(traj, success=False) == "empty_plan"
    assert planner_stats(traj, success=False).empty_plan == 1


def test_planner_stats_with_a_parse_error_stop():
    traj = episode("parse_error", planner_steps=3)
    # planner_steps = max counter (1, 2, 3); one protocol error; no backend error
    assert planner_stats(traj) == PlannerStats(
        planner_steps=3, parse_errors=1, backend_errors=0, planner_output_error=1, empty_plan=0
    )


def test_planner_stats_counts_invalid_ids_and_backend_errors():
    traj = episode("backend_error", planner_steps="4")  # counters may be serialised as text
    traj["trajectory"][2]["policy_decision"]["status"] = "invalid_action_id"
    # decisions: invalid_action_id (step 2), backend_error (stop) -> 1 + 1 = 2
    assert planner_stats(traj) == PlannerStats(
        planner_steps=4, parse_errors=1, backend_errors=1, planner_output_error=2, empty_plan=0
    )


@pytest.mark.parametrize(("success", "expected"), [(False, 1), (True, 0)])
def test_empty_plan_is_done_without_success(success, expected):
    assert planner_stats(episode("done", success=success)).empty_plan == expected


def test_empty_plan_needs_done():
    assert planner_stats(episode("max_steps")).empty_plan == 0


def test_no_decisions_at_all():
    traj = make_traj(make_config(), [step("agent_1", "Find", BOX)])
    assert policy_decisions(traj) == []
    assert planner_stats(traj) == PlannerStats(0, 0, 0, 0, 0)


def test_bad_planner_counter_raises_naming_the_field():
    traj = episode("done", planner_steps="many")
    with pytest.raises(TrajectoryError) as info:
        planner_stats(traj)
    assert info.value.field == "trajectory[3].policy_decision.planner_steps"


def test_decisions_need_a_trajectory_list():
    with pytest.raises(TrajectoryError) as info:
        terminal_reason({"task_config": {}})
    assert info.value.field == "trajectory"


def test_episode_result_carries_failure_fields():
    r = score_trajectory(episode("done", planner_steps=3))
    assert (r.terminal_reason, r.failure_kind, r.empty_plan) == ("done", "empty_plan", 1)
    assert (r.planner_steps, r.parse_errors, r.backend_errors, r.planner_output_error) == (
        3,
        0,
        0,
        0,
    )


def test_d2_illegal_success_keeps_goal_based_failure_fields():
    # Goals met by an illegal D2 plan: task_success is gated to 0, but the terminal-state
    # classification and empty_plan use the raw goal check, as the reference's empty_plan.
    config = make_config("D2", "C", objects={"container": BOX})
    r = score_trajectory(illegal_success(config, stop("done")))
    assert (r.task_success, r.legal_plan, r.failure_kind, r.empty_plan) == (0, 0, "success", 0)
