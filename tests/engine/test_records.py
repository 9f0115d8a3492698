"""`run.json` keeps the request once; run folders of earlier layouts are read through the
documented converter (`engine.records.upgrade`) and resume."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.engine.records import RECORD_VERSION, request_from_record, upgrade
from cocobench_agents.engine.request import RunRequest

FIXTURES = Path(__file__).resolve().parents[1] / "report" / "fixtures"


def test_the_record_holds_the_request_once(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--suite", "demo", "--model", "greedy", "--limit", "1",
                 "--max-steps", "2", "--jobs", "2", "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    assert record["record_version"] == RECORD_VERSION
    assert not {"cli_options", "options", "model_settings"} & set(record)
    assert set(record["plan"]) == {"task_ids", "models", "conditions"}  # what it resolved to
    request = request_from_record(record, out / "run.json")
    assert request.execution.jobs == 2 and request.max_steps == 2
    assert request.out == out.resolve() and request.selection.sources == ["demo"]


@pytest.mark.parametrize("fixture", ["run_oracle_short", "run_arms"])
def test_a_version_1_record_reads_as_its_request(fixture):
    record = json.loads((FIXTURES / fixture / "run.json").read_text())
    request = RunRequest.model_validate(upgrade(record))
    options = record["cli_options"]
    assert request.models == list(options["models"])
    assert request.selection.sources == (list(options["tasks"]) or [options["suite"]])
    assert request.epochs == options["epochs"] and request.max_steps == options["max_steps"]
    suites = options["prompt_suite"]
    assert request.prompt_suites == ([suites] if isinstance(suites, str) else suites)
    assert request.model_settings.timeout_s == options["timeout"]


def test_the_oldest_record_without_cli_options_reads_too():
    record = json.loads((FIXTURES / "run_arms" / "run.json").read_text())
    record.pop("cli_options")
    request = RunRequest.model_validate(upgrade(record))
    assert request.models == ["greedy", "random:1"] and request.epochs == 2
    assert request.conditions == ["C0_image"]
    assert request.prompt_suites == ["cocobench-v1", "cocobench-v1+no-hint"]
    assert request.model_settings.temperature == record["model_settings"]["temperature"]


def test_a_version_1_run_folder_resumes(tmp_path, capsys):
    out = tmp_path / "old"
    shutil.copytree(FIXTURES / "run_oracle_short", out)  # results without trajectories
    assert main(["run", "--out", str(out), "--resume"]) == 0
    assert "4 episodes (0 already done)" in capsys.readouterr().err  # each runs again
    assert main(["run", "--out", str(out), "--resume"]) == 0
    assert "4 episodes (4 already done)" in capsys.readouterr().err
    record = json.loads((out / "run.json").read_text())
    assert "cli_options" in record  # the record is read, never rewritten
