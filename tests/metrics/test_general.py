"""General metrics, distributed stats and the EpisodeResult record (reference §7.3, §7.6).

Expected numbers are worked out by hand in the comments, never by the code under test.
"""

from __future__ import annotations

import copy
import json

import pytest

from benchmark_adapter.metrics import (
    CommVolume,
    DistributedMetrics,
    EpisodeResult,
    TrajectoryError,
    checks_summary,
    d2_legality_gate,
    distributed_metrics,
    general_metrics,
    goal_success,
    legal_plan,
    score_trajectory,
    subgoal_success_rate,
)

from .builders import (
    BOX,
    CARD,
    HELD,
    K_SKILLS,
    KEYCHAIN,
    KNIFE,
    NO_ROOM,
    POTATO,
    SOFA,
    illegal_success,
    make_config,
    make_traj,
    step,
    stop,
)

VASE = "Vase|+01.00|+00.50|+02.00"
SKILLS = ["Find", "Explore", "Wait", "PickUp", "Put", "Drop", "BreakObject"]


def centralized_traj() -> dict:
    """Ten steps, one of most categories; worked numbers in test_centralized_general_metrics."""
    config = make_config(
        "D1",
        "G",
        skills=SKILLS,
        objects={"item_1": KEYCHAIN, "item_2": CARD, "target_1": SOFA, "target_2": BOX},
        constraints={"fragile_objects": [VASE], "optimal_makespan": 4},
    )
    items = [
        step("agent_1", "Find", KEYCHAIN),  # 1 progress
        step("agent_1", "PickUp", KEYCHAIN),  # 2 progress
        step("agent_1", "Put", KEYCHAIN, to=SOFA, ok=False, error=NO_ROOM),  # 3 affordance
        step("agent_1", "Put", KEYCHAIN, to=SOFA),  # 4 progress
        step(
            "agent_2",
            "Find",
            CARD,
            ok=False,
            error=f"Could not navigate to a visible, unoccupied pose for {CARD}",
        ),  # 5 occupancy
        step("agent_2", "Wait"),  # 6 idle_wait
        step("agent_2", "BreakObject", VASE),  # 7 progress
        step("agent_2", "PickUp", CARD, ok=False, error=f"{CARD} is not pickupable"),  # 8 precond
        step("agent_1", "Explore", ok=False, error="MoveAhead failed"),  # 9 action_failure
        step("agent_1", "Slice", KEYCHAIN),  # 10 illegal
        stop("max_steps", policy="harness"),
    ]
    return make_traj(config, items, success=False, passed=1, total=2)


def test_centralized_general_metrics():
    m = general_metrics(centralized_traj())
    assert (m.success, m.success_with_d2_legality_gate) == (False, False)
    assert m.subgoal_success_rate == 0.5  # 1 of 2 checks
    assert m.checks == "1/2"
    assert m.legal_plan is False  # one illegal skill and one precondition violation
    assert m.n_action_steps == 10
    assert m.n_agents == 2
    assert m.per_agent_actions == {"agent_1": 6, "agent_2": 4}  # steps 1-4,9,10 / 5-8
    assert m.makespan == 6
    assert m.load_imbalance == 2  # 6 - 4
    assert m.wait_steps == 1
    assert m.failed_steps == 4  # steps 3, 5, 8, 9 (the Wait succeeded)
    assert m.coordination_overhead == 5  # 1 wait + 4 failed
    assert m.illegal_skill == 1
    assert m.dependency_violations == 1
    assert m.concurrency_conflicts == 0
    assert m.occupancy_conflicts == 1
    assert m.affordance_failures == 1
    assert m.affordance_accuracy == 0.5  # 1 successful Put / (1 + 1 "no valid positions")
    assert m.safety_violations == 1  # BreakObject on the fragile vase
    assert m.invalid_action_ratio == 0.4  # 4 failed / 10
    assert m.event_histogram == {  # sorted by name, zero categories left out
        "action_failure": 1,
        "affordance_miss": 1,
        "idle_wait": 1,
        "illegal_skill": 1,
        "occupancy_conflict": 1,
        "precondition_violation": 1,
        "progress": 4,
    }
    assert distributed_metrics(centralized_traj()) is None


def test_load_imbalance_ignores_agents_that_never_acted():
    config = make_config(n_agents=3)
    traj = make_traj(config, [step("agent_1", "Find", BOX)] * 3 + [step("agent_2", "Find", BOX)])
    m = general_metrics(traj)
    assert m.per_agent_actions == {"agent_1": 3, "agent_2": 1}
    assert m.makespan == 3
    # Reference QUIRK: agent_3 never acted, so it is not a 0: 3 - 1, not 3 - 0.
    assert m.load_imbalance == 2
    assert m.n_agents == 3


def test_empty_episode():
    traj = make_traj(make_config(), [stop("parse_error")])
    m = general_metrics(traj)
    assert m.legal_plan is None
    assert (m.n_action_steps, m.makespan, m.load_imbalance) == (0, 0, 0)
    assert m.invalid_action_ratio == 0.0
    assert m.affordance_accuracy is None
    assert m.subgoal_success_rate is None  # no checks at all
    assert m.checks == "0/0"
    assert m.event_histogram == {}


def test_d2_success_needs_a_legal_plan():
    config = make_config(
        "D2", "C", objects={"container": BOX}, constraints={"precedence": [["a", "b"]]}
    )
    illegal = illegal_success(config)
    m = general_metrics(illegal)
    assert (m.success, m.legal_plan, m.success_with_d2_legality_gate) == (True, False, False)
    assert score_trajectory(illegal).task_success == 0
    legal = make_traj(config, [step("agent_1", "Open", BOX)], success=True, passed=1, total=1)
    assert score_trajectory(legal).task_success == 1


def test_d2_gate_only_applies_to_d2():
    assert d2_legality_gate("D1", True, False) is True
    assert d2_legality_gate("D2", True, False) is False
    assert d2_legality_gate("D2", True, None) is False  # as the reference: `not legal_plan`
    assert d2_legality_gate("D2", False, True) is False
    assert d2_legality_gate("D2", True, True) is True


def test_small_accessors():
    traj = centralized_traj()
    assert goal_success(traj) is False
    assert subgoal_success_rate(traj) == 0.5
    assert checks_summary(traj) == "1/2"
    assert legal_plan(traj) is False


def test_final_eval_falls_back_to_last_item_eval():
    traj = make_traj(make_config(), [step("agent_1", "Find", BOX)])
    del traj["final_eval"]
    traj["trajectory"][-1]["eval"] = {"success": True, "checks": [{"passed": True}]}
    assert goal_success(traj) is True
    assert checks_summary(traj) == "1/1"


@pytest.mark.parametrize(
    ("mutate", "field"),
    [
        (lambda t: [t.pop("final_eval"), t["trajectory"][-1].pop("eval")], "final_eval"),
        (lambda t: t["final_eval"].pop("success"), "final_eval.success"),
        (lambda t: t["final_eval"].__setitem__("checks", [1]), "final_eval.checks[0]"),
    ],
)
def test_missing_eval_fields_raise(mutate, field):
    traj = make_traj(make_config(), [step("agent_1", "Find", BOX)])
    mutate(traj)
    with pytest.raises(TrajectoryError) as info:
        general_metrics(traj)
    assert info.value.field == field


def distributed_traj() -> dict:
    """Two rounds of two agents (K_D3-like)."""
    config = make_config(
        "D3",
        "K",
        skills=K_SKILLS,
        objects={"item_1": POTATO, "knife": KNIFE},
        constraints={"resource_exclusion": [{"resource_id": KNIFE}]},
    )
    items = [
        step("agent_1", "PickUp", KNIFE, round_index=1, message="I take the knife"),
        step("agent_2", "PickUp", KNIFE, ok=False, round_index=1, message="after you", error=HELD),
        step(
            "agent_1",
            "Find",
            POTATO,
            ok=False,
            round_index=2,
            error="Could not navigate to a visible, unoccupied pose",
        ),
        step("agent_2", "Explore", ok=False, round_index=2, error="blocked"),
        stop("all_idle", policy="distributed"),
    ]
    return make_traj(config, items, success=False, passed=0, total=1)


def test_distributed_two_rounds():
    d = distributed_metrics(distributed_traj())
    assert d == DistributedMetrics(
        n_rounds=2,
        decision_parallelism=2.0,  # 4 landed steps / 2 rounds
        redundant_work_rate=0.25,  # round 1: two PickUps of the knife -> 1 duplicate / 4 landed
        deadlock_rate=0.5,  # round 2 has no successful step: 1 / 2 rounds
        comm_volume=CommVolume(messages=2, tokens=6, per_round=1.0),  # 4 + 2 words
        comm_efficiency=0.5,  # 1 progress step (round-1 PickUp) / 2 messages
    )


def test_distributed_without_messages_has_no_comm_efficiency():
    traj = distributed_traj()
    for item in traj["trajectory"]:
        item.pop("message", None)
    d = distributed_metrics(traj)
    assert d.comm_efficiency is None
    assert d.comm_volume == CommVolume(messages=0, tokens=0, per_round=0.0)


def test_episode_result_flat_fields():
    r = score_trajectory(
        centralized_traj(),
        backend="litellm",
        models="gpt-x",
        planner="centralized",
        obs_mode="blind",
        prompt_suite="paper-v1",
    )
    assert (r.task_id, r.cell, r.family, r.dim) == ("G_D1__FloorPlan201__seed0", "G_D1", "G", "D1")
    assert (r.agent_count, r.scene) == (2, "FloorPlan201")
    assert (r.backend, r.models, r.planner) == ("litellm", "gpt-x", "centralized")
    assert (r.obs_mode, r.prompt_suite, r.schema_version) == ("blind", "paper-v1", 1)
    assert (r.task_success, r.task_progress, r.checks, r.legal_plan) == (0, 0.5, "1/2", 0)
    # D1: sample 10 steps; M = 6 (agent_1), M* = 4 declared -> 4/6
    assert (r.construct_status, r.construct_sample) == ("scored", 10)
    assert r.construct_score == pytest.approx(4 / 6)
    assert (r.num_steps, r.num_invalid_actions, r.num_invalid_action_ratio) == (10, 4, 0.4)
    assert (r.failed_steps, r.dependency_violations, r.occupancy_conflicts) == (4, 1, 1)
    assert (r.affordance_failures, r.illegal_skill) == (1, 1)
    assert (r.terminal_reason, r.failure_kind) == ("max_steps", "budget_exhaustion")
    assert r.taxonomy["progress"] == 4
    assert r.general.per_agent_actions == {"agent_1": 6, "agent_2": 4}
    assert r.distributed is None
    assert list(r.cross_construct) == ["D1", "D2", "D3", "D4"]
    assert r.cross_construct["D1"].score == r.construct_score


def test_models_may_be_a_per_agent_mapping():
    r = score_trajectory(distributed_traj(), models={"agent_1": "a", "agent_2": "b"})
    assert r.models == {"agent_1": "a", "agent_2": "b"}
    assert r.distributed.n_rounds == 2


def test_identifiers_are_checked():
    with pytest.raises(TypeError, match="colour"):
        score_trajectory(centralized_traj(), colour="red")
    with pytest.raises(TypeError, match="task_id"):
        score_trajectory(centralized_traj(), task_id="other")  # derived from the trajectory


def test_task_id_falls_back_to_config_and_is_required():
    traj = centralized_traj()
    del traj["task_id"]
    assert score_trajectory(traj).task_id == "G_D1__FloorPlan201__seed0"
    del traj["task_config"]["task_id"]
    with pytest.raises(TrajectoryError) as info:
        score_trajectory(traj)
    assert info.value.field == "task_id"


@pytest.mark.parametrize("build", [centralized_traj, distributed_traj])
def test_scoring_twice_gives_byte_identical_json(build):
    traj = build()
    pristine = copy.deepcopy(traj)
    first = score_trajectory(traj, models={"agent_2": "b", "agent_1": "a"}).model_dump_json()
    second = score_trajectory(build(), models={"agent_2": "b", "agent_1": "a"}).model_dump_json()
    assert first.encode() == second.encode()
    assert traj == pristine  # scoring never mutates its input
    # The dump round-trips through the model and is plain JSON.
    assert EpisodeResult.model_validate_json(first).model_dump_json() == first
    assert json.loads(first)["models"] == {"agent_2": "b", "agent_1": "a"}
