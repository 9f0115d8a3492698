"""The `cocobench` command: list, validate, score (exit codes, messages, JSON output)."""

from __future__ import annotations

import json
import shutil
import subprocess
from importlib import resources
from pathlib import Path

import pytest

from benchmark_adapter.oracles import run_oracle
from benchmark_adapter.tasks import load_tasks
from benchmark_adapter.trajectory import dumps
from cocobench_agents.cli import main

DEMO_DIR = Path(str(resources.files("benchmark_adapter") / "data" / "demo"))
DEMO_IDS = ["C_D2__DemoBedroom1__3agent_seed0", "G_D1__DemoLivingRoom1__seed0",
            "J_D4__DemoBedroom2__seed0", "K_D3__DemoKitchen1__seed0"]


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


# -- list ------------------------------------------------------------------------------------

def test_list_demo_table(capsys) -> None:
    code, out, err = run(capsys, "list", "demo")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert lines[0].split() == ["task_id", "cell", "family", "dim", "agents", "scene", "room",
                                "budget"]
    assert set(lines[1]) == {"─"}
    assert [line.split()[0] for line in lines[2:6]] == DEMO_IDS
    assert lines[4].split() == ["J_D4__DemoBedroom2__seed0", "J_D4", "J", "D4", "2",
                                "DemoBedroom2", "bedroom", "60"]
    assert lines[-1] == "4 instances"


def test_list_demo_json(capsys) -> None:
    code, out, _ = run(capsys, "list", "demo", "--json")
    assert code == 0
    records = json.loads(out)
    assert [r["task_id"] for r in records] == DEMO_IDS
    for record in records:
        assert set(record) == {"task_id", "cell", "family", "dim", "agents", "scene", "room",
                               "task_type", "budget"}
    assert records[0] == {"task_id": "C_D2__DemoBedroom1__3agent_seed0", "cell": "C_D2",
                          "family": "C", "dim": "D2", "agents": 3, "scene": "DemoBedroom1",
                          "room": "bedroom", "task_type": None, "budget": 34}
    assert records[3] == {"task_id": "K_D3__DemoKitchen1__seed0", "cell": "K_D3",
                          "family": "K", "dim": "D3", "agents": 2, "scene": "DemoKitchen1",
                          "room": "kitchen", "task_type": None, "budget": 24}


def test_list_a_folder_and_a_file(capsys, tmp_path: Path) -> None:
    shutil.copy(DEMO_DIR / "G_D1__DemoLivingRoom1__seed0.json", tmp_path)
    code, out, _ = run(capsys, "list", str(tmp_path), "--json")
    assert code == 0
    assert [r["task_id"] for r in json.loads(out)] == ["G_D1__DemoLivingRoom1__seed0"]
    code, out, _ = run(capsys, "list", str(tmp_path / "G_D1__DemoLivingRoom1__seed0.json"))
    assert code == 0 and out.splitlines()[-1] == "1 instances"


def test_unknown_suite(capsys) -> None:
    code, out, err = run(capsys, "list", "nosuchsuite")
    assert code == 2
    assert out == ""
    assert "nosuchsuite" in err
    assert "available suites:" in err and "demo" in err


def test_validate_unknown_suite(capsys) -> None:
    code, _, err = run(capsys, "validate", "nosuchsuite")
    assert code == 2 and "available suites:" in err and "demo" in err


# -- validate --------------------------------------------------------------------------------

def test_validate_demo(capsys) -> None:
    code, out, _ = run(capsys, "validate", "demo")
    assert code == 0
    for task_id in DEMO_IDS:
        assert task_id in out
    assert "4/4 passed" in out
    assert sum(line.endswith(" pass") for line in out.splitlines()) == 4


def test_validate_demo_in_parallel(capsys) -> None:
    code, out, _ = run(capsys, "validate", "demo", "--jobs", "2")
    assert code == 0 and "4/4 passed" in out
    rows = [line.split()[0] for line in out.splitlines() if line.startswith(("C_", "G_", "J_",
                                                                               "K_"))]
    assert rows == DEMO_IDS


def test_validate_folder_with_a_broken_config(capsys, tmp_path: Path) -> None:
    shutil.copy(DEMO_DIR / "G_D1__DemoLivingRoom1__seed0.json", tmp_path)
    broken = json.loads((DEMO_DIR / "K_D3__DemoKitchen1__seed0.json").read_text())
    broken["agent_count"] = "two"
    bad = tmp_path / "K_D3__Broken__seed0.json"
    bad.write_text(json.dumps(broken), encoding="utf-8")
    code, out, err = run(capsys, "validate", str(tmp_path))
    assert code == 2
    assert str(bad) in err
    assert "agent_count" in err
    assert out == ""


def test_validate_folder_with_a_missing_field(capsys, tmp_path: Path) -> None:
    broken = json.loads((DEMO_DIR / "G_D1__DemoLivingRoom1__seed0.json").read_text())
    del broken["init_state"]["objects"]
    bad = tmp_path / "nested" / "G_D1__Broken__seed0.json"
    bad.parent.mkdir()
    bad.write_text(json.dumps(broken), encoding="utf-8")
    code, _, err = run(capsys, "validate", str(tmp_path))
    assert code == 2
    assert str(bad) in err and "init_state.objects" in err


def test_validate_reports_a_failing_instance(capsys, tmp_path: Path) -> None:
    config = json.loads((DEMO_DIR / "G_D1__DemoLivingRoom1__seed0.json").read_text())
    config["goal_predicates"][0] = {"predicate": "open", "object": "item_1"}
    (tmp_path / "G_D1__Unreachable__seed0.json").write_text(json.dumps(config))
    code, out, _ = run(capsys, "validate", str(tmp_path))
    assert code == 1
    assert "0/1 passed" in out and "oracle: goal not reached" in out


# -- score -----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def trajectory_text() -> str:
    config = next(t for t in load_tasks("demo") if t.cell == "K_D3")
    return dumps(run_oracle(config))


@pytest.fixture
def good(tmp_path: Path, trajectory_text: str) -> Path:
    path = tmp_path / "run" / "trajectory.json"
    path.parent.mkdir()
    path.write_text(trajectory_text, encoding="utf-8")
    return path


def test_score_table(capsys, good: Path) -> None:
    code, out, err = run(capsys, "score", str(good))
    assert code == 0 and err == ""
    header, _, row = out.splitlines()
    assert header.split() == ["task_id", "success", "progress", "legal", "construct", "status",
                              "sample", "steps", "terminal"]
    assert row.split() == ["K_D3__DemoKitchen1__seed0", "1", "1.00", "1", "1.00", "scored",
                           "2", "18", "done"]


def test_score_json_and_rescoring_is_byte_identical(capsys, good: Path) -> None:
    code, first, _ = run(capsys, "score", "--json", str(good))
    assert code == 0
    code, second, _ = run(capsys, "score", "--json", str(good))
    assert code == 0
    assert first == second
    [record] = json.loads(first)
    assert record["task_id"] == "K_D3__DemoKitchen1__seed0"
    assert (record["task_success"], record["legal_plan"], record["checks"]) == (1, 1, "2/2")
    assert (record["construct_score"], record["construct_status"]) == (1.0, "scored")
    assert record["num_steps"] == 18
    assert record["terminal_reason"] == "done"


def test_score_bad_files_are_reported_and_skipped(capsys, good: Path, tmp_path: Path) -> None:
    not_json = tmp_path / "broken.json"
    not_json.write_text("{not json", encoding="utf-8")
    document = json.loads(good.read_text())
    del document["trajectory"]
    no_items = tmp_path / "no_items.json"
    no_items.write_text(json.dumps(document), encoding="utf-8")

    code, out, err = run(capsys, "score", "--json", str(not_json), str(good), str(no_items))
    assert code == 2
    assert [r["task_id"] for r in json.loads(out)] == ["K_D3__DemoKitchen1__seed0"]
    lines = err.strip().splitlines()
    assert len(lines) == 2
    assert str(not_json) in lines[0] and "JSON" in lines[0]
    assert str(no_items) in lines[1] and "trajectory" in lines[1]


def test_score_table_with_a_bad_file(capsys, good: Path, tmp_path: Path) -> None:
    missing = tmp_path / "absent.json"
    code, out, err = run(capsys, "score", str(good), str(missing))
    assert code == 2
    assert "K_D3__DemoKitchen1__seed0" in out
    assert str(missing) in err


def test_score_needs_a_file(capsys) -> None:
    code, _, err = run(capsys, "score")
    assert code == 2 and err


# -- the installed console script -------------------------------------------------------------

def test_console_script_version() -> None:
    exe = shutil.which("cocobench")
    if exe is None:
        pytest.skip("the cocobench console script is not on PATH")
    done = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0
    assert done.stdout.strip() == "cocobench, version 0.1.0"
