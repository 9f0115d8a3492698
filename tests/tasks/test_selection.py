"""Eval-set selection: cell, dim, family, curated, task id, dedupe, filters, limit."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmark_adapter.tasks import (
    TaskConfig,
    TaskConfigError,
    eval_sets_of,
    load_tasks,
    select_tasks,
)
from tests.paths import SHARED_DATA

DATA = SHARED_DATA


def task(task_id: str) -> TaskConfig:
    """A minimal config whose family and dim come from the id prefix (`K_D3__…`)."""
    family, dim = task_id.split("__")[0].split("_")
    return TaskConfig.model_validate(
        {
            "task_id": task_id,
            "coordination_dim": dim,
            "task_family": family,
            "task_name": "demo",
            "scene_id": "FloorPlan1",
            "agent_count": 1,
            "agents": [{"id": "agent_1"}],
            "init_state": {"controller_init": {"scene": "FloorPlan1"}, "objects": {}},
        }
    )


IDS = ["K_D3__a", "A_D1__b", "C_D2__c", "C_D4__d", "K_D3__e", "G_D1__f"]


@pytest.fixture
def tasks() -> list[TaskConfig]:
    return [task(i) for i in IDS]


def ids(selected: list[TaskConfig]) -> list[str]:
    return [t.task_id for t in selected]


def test_eval_sets_of(tasks: list[TaskConfig]) -> None:
    sets = eval_sets_of(tasks)
    assert sets["by_cell"]["K_D3"] == ["K_D3__a", "K_D3__e"]
    assert sets["by_dim"]["D1"] == ["A_D1__b", "G_D1__f"]
    assert sets["by_family"]["C"] == ["C_D2__c", "C_D4__d"]
    assert list(sets["by_cell"]) == sorted(sets["by_cell"])
    assert sets["curated"] == {}


def test_no_eval_set_selects_all_in_order(tasks: list[TaskConfig]) -> None:
    assert ids(select_tasks(tasks)) == IDS


def test_by_cell_dim_family(tasks: list[TaskConfig]) -> None:
    assert ids(select_tasks(tasks, ["K_D3"])) == ["K_D3__a", "K_D3__e"]
    assert ids(select_tasks(tasks, ["D1"])) == ["A_D1__b", "G_D1__f"]
    assert ids(select_tasks(tasks, ["C"])) == ["C_D2__c", "C_D4__d"]


def test_literal_task_id(tasks: list[TaskConfig]) -> None:
    assert ids(select_tasks(tasks, "C_D4__d")) == ["C_D4__d"]


def test_concatenated_and_deduplicated_in_order(tasks: list[TaskConfig]) -> None:
    selected = select_tasks(tasks, ["G_D1__f", "D1", "K", "K_D3__e"])
    assert ids(selected) == ["G_D1__f", "A_D1__b", "K_D3__a", "K_D3__e"]


def test_comma_separated_names(tasks: list[TaskConfig]) -> None:
    assert ids(select_tasks(tasks, "G, A_D1")) == ["G_D1__f", "A_D1__b"]


def test_curated_from_subset_dict_and_index_dict(tasks: list[TaskConfig]) -> None:
    subset = {"name": "mini", "task_ids": ["C_D4__d", "not_loaded", "A_D1__b"]}
    assert ids(select_tasks(tasks, ["mini"], index=subset)) == ["C_D4__d", "A_D1__b"]
    index = {"eval_sets": {"curated": {"mini": ["K_D3__e"]}}}
    assert ids(select_tasks(tasks, ["mini"], index=index)) == ["K_D3__e"]


def test_curated_from_subset_files(tmp_path: Path, tasks: list[TaskConfig]) -> None:
    one = tmp_path / "one.json"
    one.write_text(json.dumps({"task_ids": ["K_D3__e"]}))  # no name: the file stem is used
    two = tmp_path / "two.json"
    two.write_text(json.dumps({"name": "pair", "task_ids": ["A_D1__b", "G_D1__f"]}))
    selected = select_tasks(tasks, ["pair", "one"], index=[one, two])
    assert ids(selected) == ["A_D1__b", "G_D1__f", "K_D3__e"]


def test_index_sets_take_precedence_over_derived(tasks: list[TaskConfig]) -> None:
    index = {"eval_sets": {"by_cell": {"K_D3": ["K_D3__e"]}}}
    assert ids(select_tasks(tasks, ["K_D3"], index=index)) == ["K_D3__e"]


def test_lookup_order_cell_before_task_id(tasks: list[TaskConfig]) -> None:
    # A curated set named like a task id wins over the literal id.
    index = {"curated": {"A_D1__b": ["G_D1__f"]}}
    assert ids(select_tasks(tasks, ["A_D1__b"], index=index)) == ["G_D1__f"]


def test_unknown_eval_set(tasks: list[TaskConfig]) -> None:
    with pytest.raises(TaskConfigError, match="'Z_D9'") as info:
        select_tasks(tasks, ["K_D3", "Z_D9"])
    assert "by_cell: A_D1" in str(info.value)


def test_bad_index(tasks: list[TaskConfig]) -> None:
    with pytest.raises(TaskConfigError, match="no eval sets"):
        select_tasks(tasks, ["K"], index={"something": 1})


def test_only_filters(tasks: list[TaskConfig]) -> None:
    assert ids(select_tasks(tasks, only_family="C")) == ["C_D2__c", "C_D4__d"]
    assert ids(select_tasks(tasks, only_dim="D3")) == ["K_D3__a", "K_D3__e"]
    assert ids(select_tasks(tasks, ["C"], only_cell="C_D4")) == ["C_D4__d"]
    assert select_tasks(tasks, ["K"], only_dim="D1") == []


def test_task_id_filter(tasks: list[TaskConfig]) -> None:
    assert ids(select_tasks(tasks, ["K"], task_ids=["K_D3__e", "A_D1__b"])) == ["K_D3__e"]
    with pytest.raises(TaskConfigError, match="no loaded task has id nope"):
        select_tasks(tasks, task_ids=["nope"])


def test_limit(tasks: list[TaskConfig]) -> None:
    assert ids(select_tasks(tasks, ["D3", "D1"], limit=3)) == ["K_D3__a", "K_D3__e", "A_D1__b"]
    assert len(select_tasks(tasks, limit=0)) == len(IDS)


@pytest.mark.skipif(not DATA.is_dir(), reason=f"shared CoCoBench data not found at {DATA}")
def test_real_data_with_rep240_subset() -> None:
    tasks = load_tasks(DATA / "tasks")
    rep240 = DATA / "index" / "rep240.json"
    selected = select_tasks(tasks, ["rep240"], index=rep240)
    assert len(selected) == 34
    assert len(select_tasks(tasks, ["K_D3"])) == 5
    assert len(select_tasks(tasks, ["rep240"], index=rep240, only_dim="D4")) == len(
        [t for t in selected if t.coordination_dim == "D4"]
    )
