"""Malformed configs: every error names the file and the failing field."""

from __future__ import annotations

import json
import pickle
from pathlib import Path
from typing import Any

import pytest

from benchmark_adapter.tasks import TaskConfigError, load_task, load_tasks


def minimal(task_id: str = "K_D3__FloorPlan1__seed0") -> dict[str, Any]:
    """Smallest valid config: one agent, two important objects, two goals."""
    return {
        "task_id": task_id,
        "coordination_dim": "D3",
        "task_family": "K",
        "task_name": "demo",
        "scene_id": "FloorPlan1",
        "agent_count": 1,
        "agents": [{"id": "agent_1"}],
        "init_state": {
            "controller_init": {"scene": "FloorPlan1"},
            "objects": {"apple": "Apple|1|2|3", "bread": "Bread|1|2|3"},
        },
        "goal_predicates": [
            {"predicate": "sliced_by", "object": "apple", "agent": "agent_1"},
            {"predicate": "sliced_by", "object": "bread", "agent": "agent_1"},
        ],
        "difficulty": {"step_budget": 10},
    }


def write(path: Path, data: Any) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(data if isinstance(data, str) else json.dumps(data), encoding="utf-8")
    return path


def error_for(path: Path) -> TaskConfigError:
    with pytest.raises(TaskConfigError) as info:
        load_task(path)
    assert str(path) in str(info.value)
    return info.value


def test_message_format() -> None:
    assert str(TaskConfigError("a.json", "bad", "x.y")) == "a.json: x.y: bad"
    assert str(TaskConfigError("a.json", "bad")) == "a.json: bad"
    err = TaskConfigError("a.json", "bad", "x")
    assert isinstance(err, ValueError) and (err.path, err.field) == ("a.json", "x")


def test_error_survives_pickling() -> None:
    err = pickle.loads(pickle.dumps(TaskConfigError("a.json", "bad", "x")))
    assert (err.path, err.field, str(err)) == ("a.json", "x", "a.json: x: bad")


def test_invalid_json_names_line_and_column(tmp_path: Path) -> None:
    path = write(tmp_path / "t.json", '{\n  "task_id": "x",\n  oops\n}')
    err = error_for(path)
    assert err.field is None
    assert "invalid JSON at line 3, column 3" in str(err)


def test_a_file_that_is_not_json_is_decoded_once(tmp_path: Path, monkeypatch) -> None:
    # Only an integer too long to convert is decoded a second time (to name it).
    from benchmark_adapter.tasks import loading

    decoded, loads = [], json.loads
    monkeypatch.setattr(loading.json, "loads",
                        lambda text, **options: decoded.append(1) or loads(text, **options))
    path = write(tmp_path / "t.json", '{\n  "task_id": "x",\n  oops\n}')
    assert "invalid JSON at line 3, column 3" in str(error_for(path))
    assert decoded == [1]


def test_missing_task_id(tmp_path: Path) -> None:
    data = minimal()
    del data["task_id"]
    err = error_for(write(tmp_path / "t.json", data))
    assert err.field == "task_id"
    assert str(err) == f"{tmp_path / 't.json'}: task_id: Field required"


def test_missing_nested_objects(tmp_path: Path) -> None:
    data = minimal()
    del data["init_state"]["objects"]
    assert error_for(write(tmp_path / "t.json", data)).field == "init_state.objects"


def test_missing_agent_id_is_dotted_with_index(tmp_path: Path) -> None:
    data = minimal()
    del data["agents"][0]["id"]
    assert error_for(write(tmp_path / "t.json", data)).field == "agents.0.id"


def test_goal_alias_not_in_objects(tmp_path: Path) -> None:
    data = minimal()
    data["goal_predicates"][1]["object"] = "cake"
    err = error_for(write(tmp_path / "t.json", data))
    assert err.field == "goal_predicates.1.object"
    assert "'cake' is not defined in init_state.objects" in str(err)


def test_assignment_alias_not_in_objects(tmp_path: Path) -> None:
    data = minimal()
    data["assignment"] = {"cake": "agent_1"}
    assert error_for(write(tmp_path / "t.json", data)).field == "assignment.cake"


def test_wrong_type_shows_value(tmp_path: Path) -> None:
    data = minimal()
    data["agent_count"] = "two"
    err = error_for(write(tmp_path / "t.json", data))
    assert err.field == "agent_count"
    assert "valid integer" in str(err) and "'two'" in str(err)


def test_wrong_container_type(tmp_path: Path) -> None:
    data = minimal()
    data["init_state"]["objects"] = ["Apple|1|2|3"]
    err = error_for(write(tmp_path / "t.json", data))
    assert err.field == "init_state.objects" and "dictionary" in str(err)


def test_several_errors_report_the_first_and_count_the_rest(tmp_path: Path) -> None:
    data = minimal()
    del data["task_id"], data["scene_id"]
    err = error_for(write(tmp_path / "t.json", data))
    assert err.field == "task_id" and "and 1 more error" in str(err)


def test_duplicated_ids_name_both_files(tmp_path: Path) -> None:
    first = write(tmp_path / "a" / "t.json", minimal("same"))
    second = write(tmp_path / "b" / "t.json", minimal("same"))
    with pytest.raises(TaskConfigError) as info:
        load_tasks(tmp_path)
    err = info.value
    assert err.field == "task_id"
    assert str(first) in str(err) and str(second) in str(err) and "'same'" in str(err)


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ([minimal()], "got a JSON array"),
        ("just text", "got a JSON string"),
        ({"comment": "hello"}, "not a task config"),
        ({"name": "s", "task_ids": []}, "subset file, not a task config"),
    ],
)
def test_json_that_is_not_a_config(tmp_path: Path, data: Any, expected: str) -> None:
    path = write(tmp_path / "t.json", json.dumps(data))
    assert expected in str(error_for(path))


def test_single_file_that_is_not_a_config_via_load_tasks(tmp_path: Path) -> None:
    path = write(tmp_path / "list.json", "[1, 2]")
    with pytest.raises(TaskConfigError, match="got a JSON array"):
        load_tasks(path)


def test_invalid_config_in_tree_is_an_error_naming_it(tmp_path: Path) -> None:
    write(tmp_path / "good.json", minimal("good"))
    data = minimal("bad")
    del data["init_state"]["objects"]
    bad = write(tmp_path / "sub" / "bad.json", data)
    with pytest.raises(TaskConfigError) as info:
        load_tasks(tmp_path)
    assert info.value.path == str(bad) and info.value.field == "init_state.objects"


def test_invalid_json_in_tree_is_an_error(tmp_path: Path) -> None:
    bad = write(tmp_path / "broken.json", "{")
    with pytest.raises(TaskConfigError, match="invalid JSON") as info:
        load_tasks(tmp_path)
    assert info.value.path == str(bad)


def test_bad_index_record(tmp_path: Path) -> None:
    index = write(tmp_path / "index.json", {"instances": [{"task_id": "t"}]})
    with pytest.raises(TaskConfigError) as info:
        load_tasks(index)
    assert info.value.field == "instances.0" and info.value.path == str(index)
