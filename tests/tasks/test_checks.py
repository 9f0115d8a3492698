"""Configs that load as JSON and fit the schema but cannot be a fair task are refused when
they load, with the file and the field named; every shipped config still loads."""

from __future__ import annotations

import copy
import json
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import pytest

from benchmark_adapter.goals import CHECKS
from benchmark_adapter.tasks import TaskConfigError, load_task, load_tasks
from benchmark_adapter.tasks.checks import MAX_STEP_BUDGET, PREDICATE_ARGS
from benchmark_adapter.tasks.loading import MAX_JSON_DEPTH
from tests.paths import SHARED_DATA

DEMO = Path(str(resources.files("benchmark_adapter") / "data" / "demo"))
BASE = json.loads((DEMO / "G_D1__DemoLivingRoom1__seed0.json").read_text(encoding="utf-8"))

Edit = Callable[[dict[str, Any]], Any]


def edited(edit: Edit) -> dict[str, Any]:
    config = copy.deepcopy(BASE)
    edit(config)
    return config


def refused(tmp_path: Path, data: dict[str, Any] | str | bytes) -> TaskConfigError:
    path = tmp_path / "task.json"
    if isinstance(data, bytes):
        path.write_bytes(data)
    else:
        path.write_text(data if isinstance(data, str) else json.dumps(data), encoding="utf-8")
    with pytest.raises(TaskConfigError) as info:
        load_task(path)
    assert info.value.path == str(path)
    assert "\n" not in str(info.value)  # one line
    return info.value


def goal(i: int, **fields: Any) -> Edit:
    return lambda c: c["goal_predicates"][i].update(fields)


UNFAIR: dict[str, tuple[Edit, str, str]] = {
    # name: (edit, field, words of the message)
    "no goals": (lambda c: c.update(goal_predicates=[]), "goal_predicates", "no goals"),
    "more agents declared": (lambda c: c.update(agent_count=3), "agent_count",
                             "3, but 2 agents are listed"),
    "fewer agents declared": (lambda c: c.update(agent_count=1), "agent_count",
                              "1, but 2 agents are listed"),
    "controller agents": (lambda c: c["init_state"]["controller_init"].update(agentCount=4),
                          "init_state.controller_init.agentCount", "agent_count is 2"),
    "duplicated agent": (lambda c: c["agents"][1].update(id="agent_1"), "agents.1.id",
                         "duplicated agent id 'agent_1'"),
    "agent beyond the team": (lambda c: c["agents"][1].update(id="agent_7"), "agents.1.id",
                              "agent_1 … agent_2"),
    "agent id not agent_k": (lambda c: c["agents"][0].update(id="alice"), "agents.0.id",
                             "'alice'"),
    "unknown agent skill": (lambda c: c["agents"][0]["allowed_skills"].append("Teleport"),
                            "agents.0.allowed_skills", "unknown skill 'Teleport'"),
    "unknown team skill": (lambda c: c.update(allowed_skills=["pickup"]), "allowed_skills",
                           "unknown skill 'pickup'"),
    "unknown predicate": (goal(0, predicate="levitating"), "goal_predicates.0.predicate",
                          "unknown predicate 'levitating'"),
    "goal without receptacle": (lambda c: c["goal_predicates"][1].pop("receptacle"),
                                "goal_predicates.1.receptacle", "missing"),
    "goal object not a string": (goal(0, object=5), "goal_predicates.0.object",
                                 "expected an object alias or id, got 5"),
    "goal object undefined": (goal(1, object="ghost"), "goal_predicates.1.object",
                              "'ghost' is not defined"),
    "slicer not in team": (goal(0, predicate="sliced_by", agent="agent_3"),
                           "goal_predicates.0.agent", "'agent_3' is not an agent"),
    "toggle value not boolean": (goal(0, predicate="toggled", value="false"),
                                 "goal_predicates.0.value", "expected true or false"),
    "budget missing": (lambda c: c["difficulty"].pop("step_budget"),
                       "difficulty.step_budget", "missing"),
    "budget zero": (lambda c: c["difficulty"].update(step_budget=0),
                    "difficulty.step_budget", f"between 1 and {MAX_STEP_BUDGET}"),
    "budget negative": (lambda c: c["difficulty"].update(step_budget=-5),
                        "difficulty.step_budget", "-5"),
    "budget endless": (lambda c: c["difficulty"].update(step_budget=10**9),
                       "difficulty.step_budget", "1000000000"),
}


@pytest.mark.parametrize("name", UNFAIR)
def test_an_unfair_config_is_refused_naming_file_and_field(tmp_path: Path, name: str) -> None:
    edit, field, words = UNFAIR[name]
    err = refused(tmp_path, edited(edit))
    assert err.field == field
    assert words in err.what


UNSAFE_IDS = ["../../../../tmp/x", "a/b", "/abs", "", ".", "..", "x\x00y", "x" * 129,
              "id with spaces", "G_D1__x@e1", "caf\u00e9"]


@pytest.mark.parametrize("task_id", UNSAFE_IDS)
def test_an_unsafe_task_id_is_refused(tmp_path: Path, task_id: str) -> None:
    err = refused(tmp_path, edited(lambda c: c.update(task_id=task_id)))
    assert err.field == "task_id" and "not a safe task id" in err.what
    assert len(str(err)) < len(str(tmp_path)) + 300  # a huge id is not echoed whole


def test_a_top_level_budget_is_not_a_substitute(tmp_path: Path) -> None:
    config = edited(lambda c: c["difficulty"].pop("step_budget"))
    assert config["step_budget"] == 14  # present, but the reference never reads it
    assert refused(tmp_path, config).field == "difficulty.step_budget"


def test_several_problems_report_the_first_and_count_the_rest(tmp_path: Path) -> None:
    def many(c: dict[str, Any]) -> None:
        c.update(agent_count=5, goal_predicates=[])  # and controller_init.agentCount is 2
        c["difficulty"]["step_budget"] = 0

    err = refused(tmp_path, edited(many))
    assert err.field == "agent_count" and err.what.endswith("(and 3 more problems)")


def test_ids_differing_only_in_case_would_share_a_folder(tmp_path: Path) -> None:
    for name, task_id in (("a.json", "G_D1__Room__seed0"), ("b.json", "g_d1__room__seed0")):
        config = edited(lambda c, tid=task_id: c.update(task_id=tid))
        (tmp_path / name).write_text(json.dumps(config), encoding="utf-8")
    with pytest.raises(TaskConfigError, match="differs only in case") as info:
        load_tasks(tmp_path)
    assert info.value.field == "task_id" and info.value.path == str(tmp_path / "b.json")


# -- unreadable files --------------------------------------------------------------------------

def test_non_utf8_bytes(tmp_path: Path) -> None:
    text = json.dumps(BASE).replace("living_room_parallel", "living_room_\u00e9")
    err = refused(tmp_path, text.encode("latin-1"))
    assert "not UTF-8 text (byte 0xe9 at offset" in str(err)


@pytest.mark.parametrize("depth", [MAX_JSON_DEPTH + 1, 100_000])
def test_deep_nesting(tmp_path: Path, depth: int) -> None:
    config = json.dumps(BASE)[:-1] + ', "x": ' + "[" * depth + "]" * depth + "}"
    err = refused(tmp_path, config)
    assert f"nested more than {MAX_JSON_DEPTH} levels" in str(err)


def test_nesting_up_to_the_limit_is_fine(tmp_path: Path) -> None:
    depth = MAX_JSON_DEPTH - 1  # the config object itself is the first level
    path = tmp_path / "task.json"
    path.write_text(json.dumps(BASE)[:-1] + ', "x": ' + "[" * depth + "]" * depth + "}")
    assert load_task(path).task_id == BASE["task_id"]


# -- what ships ------------------------------------------------------------------------------

def test_predicate_kinds_are_the_evaluators() -> None:
    assert set(PREDICATE_ARGS) == set(CHECKS)


@pytest.mark.parametrize("source", ["demo", "cocobench-240", "cocobench-full", "shared"])
def test_every_shipped_config_passes(source: str) -> None:
    if source == "shared":
        if not (SHARED_DATA / "tasks").is_dir():
            pytest.skip("shared CoCoBench data not present")
        source = str(SHARED_DATA / "tasks")
    counts = {"demo": 4, "cocobench-240": 240, "cocobench-full": 897}
    assert len(load_tasks(source)) == counts.get(source, 36)
