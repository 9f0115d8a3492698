"""Loading task configs from files, folders, index files, subset files and suite names."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmark_adapter.tasks import (
    MissingTasksWarning,
    TaskConfig,
    TaskConfigError,
    available_suites,
    load_task,
    load_tasks,
    loading,
)
from tests.paths import SHARED_DATA

DATA = SHARED_DATA
TASKS = DATA / "tasks"
REP240 = DATA / "index" / "rep240.json"
REAL_FILES = sorted(TASKS.glob("*.json")) if TASKS.is_dir() else []

needs_data = pytest.mark.skipif(
    not TASKS.is_dir(), reason=f"shared CoCoBench data not found at {DATA}"
)


def minimal(task_id: str = "K_D3__FloorPlan1__seed0", family: str = "K", dim: str = "D3") -> dict:
    """Smallest valid config: one agent, one important object, one goal."""
    return {
        "task_id": task_id,
        "coordination_dim": dim,
        "task_family": family,
        "task_name": "demo",
        "scene_id": "FloorPlan1",
        "agent_count": 1,
        "agents": [{"id": "agent_1"}],
        "init_state": {
            "controller_init": {"scene": "FloorPlan1"},
            "objects": {"apple": "Apple|1|2|3"},
        },
        "goal_predicates": [{"predicate": "sliced_by", "object": "apple", "agent": "agent_1"}],
        "difficulty": {"step_budget": 10},
    }


def write(path: Path, data: object) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


# -- real data -----------------------------------------------------------------------------


@needs_data
@pytest.mark.parametrize("path", REAL_FILES, ids=[p.stem for p in REAL_FILES])
def test_each_real_config_loads(path: Path) -> None:
    task = load_task(path)
    assert task.task_id == path.stem
    assert task.source == str(path)
    assert task.agent_ids and task.important_ids


@needs_data
def test_real_folder_loads_all_36_sorted() -> None:
    tasks = load_tasks(TASKS)
    assert len(tasks) == 36
    assert [t.source for t in tasks] == [str(p) for p in REAL_FILES]


@needs_data
def test_data_root_skips_subset_file() -> None:
    # The tree holds index/rep240.json as well: it is not a config and must not be loaded.
    assert len(load_tasks(DATA)) == 36


@needs_data
def test_subset_with_missing_skip_keeps_present_ids_in_subset_order() -> None:
    ids = json.loads(REP240.read_text())["task_ids"]
    present = [i for i in ids if (TASKS / f"{i}.json").is_file()]
    with pytest.warns(MissingTasksWarning, match=r"206 of 240 tasks not found.*skipped them"):
        tasks = load_tasks(REP240, missing="skip")
    assert [t.task_id for t in tasks] == present
    assert len(tasks) == 34


@needs_data
def test_subset_with_missing_error_counts_and_names_ids() -> None:
    with pytest.raises(TaskConfigError) as info:
        load_tasks(REP240)
    err = info.value
    assert err.path == str(REP240) and err.field == "task_ids"
    assert "206 of 240" in str(err)
    assert "A_D1__FloorPlan5__seed1" in str(err)


# -- synthetic sources ---------------------------------------------------------------------


def test_single_file_source(tmp_path: Path) -> None:
    path = write(tmp_path / "one.json", minimal())
    [task] = load_tasks(path)
    assert isinstance(task, TaskConfig) and task.source == str(path)


def test_tree_is_recursive_sorted_and_skips_pool_and_non_configs(tmp_path: Path) -> None:
    write(tmp_path / "K" / "D3" / "b.json", minimal("b"))
    write(tmp_path / "A" / "D1" / "a.json", minimal("a", "A", "D1"))
    write(tmp_path / "C" / "family_goal_and_skill_pool.json", {"task_id": "not really"})
    write(tmp_path / "index.json", {"instances": []})
    write(tmp_path / "subsets" / "s.json", {"name": "s", "task_ids": ["a"]})
    write(tmp_path / "notes.json", {"comment": "not a task"})
    assert [t.task_id for t in load_tasks(tmp_path)] == ["a", "b"]


def test_index_paths_relative_to_repository_root(tmp_path: Path) -> None:
    repo = tmp_path / "benchmark"
    write(repo / "task_config" / "K" / "D3" / "t1.json", minimal("t1"))
    write(repo / "task_config" / "A" / "D1" / "t2.json", minimal("t2", "A", "D1"))
    index = write(
        repo / "task_config" / "index.json",
        {
            "instances": [
                {"task_id": "t2", "config": "task_config/A/D1/t2.json"},
                {"task_id": "t1", "config": "task_config/K/D3/t1.json"},
            ],
            "eval_sets": {"by_cell": {"K_D3": ["t1"]}},
        },
    )
    assert [t.task_id for t in load_tasks(index)] == ["t2", "t1"]


def test_index_paths_relative_to_index_folder(tmp_path: Path) -> None:
    write(tmp_path / "configs" / "t1.json", minimal("t1"))
    index = write(tmp_path / "index.json", {"instances": [{"config": "configs/t1.json"}]})
    assert [t.task_id for t in load_tasks(index)] == ["t1"]


def test_index_missing_config(tmp_path: Path) -> None:
    write(tmp_path / "configs" / "t1.json", minimal("t1"))
    index = write(
        tmp_path / "index.json",
        {"instances": [{"config": "configs/t1.json"}, {"task_id": "gone", "config": "x.json"}]},
    )
    with pytest.raises(TaskConfigError, match=r"1 of 2 tasks not found.*gone"):
        load_tasks(index)
    with pytest.warns(MissingTasksWarning, match=r"1 of 2 tasks not found.*gone") as caught:
        assert [t.task_id for t in load_tasks(index, missing="skip")] == ["t1"]
    assert caught[0].filename == __file__  # points at the caller of load_tasks


def test_subset_finds_configs_not_named_after_their_id(tmp_path: Path) -> None:
    write(tmp_path / "K" / "D3" / "renamed.json", minimal("t1"))
    subset = write(tmp_path / "subsets" / "s.json", {"name": "s", "task_ids": ["t1", "t1"]})
    assert [t.task_id for t in load_tasks(subset)] == ["t1"]


def test_missing_path_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(TaskConfigError, match="no such file or folder"):
        load_tasks(tmp_path / "nope")
    with pytest.raises(TaskConfigError, match="no such file"):
        load_tasks("nope.json")


def test_bad_missing_argument(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="missing"):
        load_tasks(tmp_path, missing="ignore")  # type: ignore[arg-type]


# -- built-in suites -------------------------------------------------------------------------


@pytest.fixture
def suites(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    root = tmp_path / "data"
    write(root / "tiny" / "K" / "t1.json", minimal("t1"))
    write(root / "tiny" / "A" / "t2.json", minimal("t2", "A", "D1"))
    (root / "empty").mkdir()
    (root / "__pycache__").mkdir()
    monkeypatch.setattr(loading, "_suites_root", lambda: root)
    monkeypatch.chdir(tmp_path)  # so a bare name is not accidentally an existing path
    return root


def test_available_suites(suites: Path) -> None:
    assert available_suites() == ["empty", "tiny"]


def test_suite_by_name(suites: Path) -> None:
    assert [t.task_id for t in load_tasks("tiny")] == ["t2", "t1"]


def test_unknown_suite_lists_available(suites: Path) -> None:
    with pytest.raises(TaskConfigError, match=r"available suites: empty, tiny") as info:
        load_tasks("huge")
    assert info.value.path == "huge"


def test_real_suites_root_is_package_data() -> None:
    assert loading._suites_root().name == "data"
    assert "demo" in available_suites()


# -- the nesting bound against a stranger's file ----------------------------------------------

def _depth(value) -> int:
    """How many levels of arrays/objects `value` nests (recursive: the reference)."""
    if not isinstance(value, (dict, list)):
        return 0
    children = value.values() if isinstance(value, dict) else value
    return 1 + max((_depth(child) for child in children), default=0)


_trees = st.recursive(st.none() | st.integers() | st.text(max_size=2),
                      lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(st.text(max_size=2), inner, max_size=3),
                      max_leaves=40)


@settings(max_examples=300, deadline=None)
@given(tree=_trees, shared=st.integers(0, 3), limit=st.integers(1, 12))
def test_depth_exceeds_is_the_nesting_depth_even_with_shared_nodes(tree, shared, limit):
    # A YAML alias shares one node at several places (and depths): the walk must count the
    # deepest, as the recursive reference does.
    for _ in range(shared):
        tree = [tree, {"again": tree}]
    assert loading.depth_exceeds(tree, limit) == (_depth(tree) > limit)
