"""Oracle plans and the instance quality gates (validation): every demo instance and every
shared config passes; parallel validation keeps input order."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmark_adapter.oracles import NoOraclePlan, run_oracle
from benchmark_adapter.tasks import load_task, load_tasks
from benchmark_adapter.validation import validate_task, validate_tasks

from .worlds import SHARED_FILES, TASKS, make_config, needs_data

DEMO = load_tasks("demo")
DEMO_IDS = ["C_D2__DemoBedroom1__3agent_seed0", "G_D1__DemoLivingRoom1__seed0",
            "J_D4__DemoBedroom2__seed0", "K_D3__DemoKitchen1__seed0"]


def test_demo_suite_is_the_four_instances() -> None:
    assert [t.task_id for t in DEMO] == DEMO_IDS


def _assert_passes(row) -> None:
    assert row.passed is True, row.reason
    assert row.reason == ""
    assert row.success is True
    assert row.legal_plan is True
    assert row.construct_status == "scored"
    assert row.construct_score >= 0.95
    assert row.steps > 0


@pytest.mark.parametrize("config", DEMO, ids=[t.task_id for t in DEMO])
def test_demo_instance_validates(config) -> None:
    row = validate_task(config)
    _assert_passes(row)
    assert (row.task_id, row.cell, row.agents) == (config.task_id, config.cell,
                                                   config.agent_count)


@needs_data
@pytest.mark.parametrize("path", SHARED_FILES, ids=[p.stem for p in SHARED_FILES])
def test_shared_config_validates(path: Path) -> None:
    _assert_passes(validate_task(load_task(path)))


@needs_data
def test_all_36_shared_configs_are_there() -> None:
    assert len(SHARED_FILES) == 36
    assert {load_task(p).cell for p in SHARED_FILES} == {
        "A_D1", "A_D2", "C_D2", "C_D4", "G_D1", "H_D1", "H_D2", "J_D4", "K_D3"}


def test_oracle_reaches_the_goal_and_stops_with_done() -> None:
    doc = run_oracle(DEMO[3])  # K_D3
    assert doc["final_eval"]["success"] is True
    last = doc["trajectory"][-1]
    assert last["label"] == "policy_stop"
    assert last["policy_decision"]["terminal_reason"] == "done"
    steps = [i for i in doc["trajectory"] if "skill_result" in i]
    assert all(s["skill_result"]["success"] for s in steps)
    # K_D3 oracle: per agent Find knife, PickUp, Find item, Slice, Drop, 4 × Explore = 9
    assert len(steps) == 18


def test_oracle_budget_cuts_the_run() -> None:
    doc = run_oracle(DEMO[3], max_steps=3)
    steps = [i for i in doc["trajectory"] if "skill_result" in i]
    assert len(steps) == 3
    assert doc["trajectory"][-1]["policy_decision"]["terminal_reason"] == "max_steps"
    assert doc["final_eval"]["success"] is False


def test_a_failing_instance_is_a_failed_row_not_an_exception() -> None:
    config = make_config(goals=[{"predicate": "sliced", "object": "tomato"}])  # cell X_D1
    with pytest.raises(NoOraclePlan):
        run_oracle(config)
    row = validate_task(config)
    assert row.passed is False
    assert row.reason.startswith("error:")


def test_a_broken_oracle_fails_the_oracle_gate() -> None:
    config = DEMO[1].model_copy(deep=True)  # G_D1, goals retargeted to an impossible state
    config.goal_predicates[0] = config.goal_predicates[0].model_validate(
        {"predicate": "open", "object": "item_1"})
    row = validate_task(config)
    assert row.passed is False
    assert row.reason.startswith("oracle: goal not reached")


def _inputs() -> list:
    configs = list(DEMO)
    if TASKS.is_dir():
        configs += [load_task(p) for p in SHARED_FILES[::6]]
    return list(reversed(configs))


def test_parallel_validation_keeps_input_order_and_results() -> None:
    configs = _inputs()
    serial = list(validate_tasks(configs, jobs=1))
    parallel = list(validate_tasks(configs, jobs=2))
    assert [r.task_id for r in serial] == [c.task_id for c in configs]
    assert parallel == serial
    assert all(r.passed for r in parallel)
