"""Runs whose settings differ are never merged into one report row (issue 12, item 10): the
report stops with a one-line error naming both runs and the setting (exit 2), unless each run
becomes its own arm (`--arms`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.cli import main
from cocobench_agents.reports import ReportError, load_runs

from .helpers import RUN_SMALL, result_lines, write_run

REMOTE = "openai/gpt-4o"


def run_copy(path: Path, *, remote: bool = False, **changes: Any) -> Path:
    """run_small, its models renamed to a remote one if asked, with `changes` applied to
    run.json (``section__field=value``)."""
    record = json.loads((RUN_SMALL / "run.json").read_text())
    lines = result_lines(RUN_SMALL)
    if remote:
        lines = [{**line, "model": REMOTE} for line in lines if line["model"] == "greedy"]
        record["plan"]["models"] = [REMOTE]
    for name, value in changes.items():
        section, field = name.split("__")
        record[section][field] = value
    write_run(path, lines)
    (path / "run.json").write_text(json.dumps(record))
    return path


def test_runs_with_the_same_settings_merge(tmp_path):
    data = load_runs([run_copy(tmp_path / "a"), run_copy(tmp_path / "b")])
    assert data.superseded_across_runs == len(data.episodes)
    assert data.models == ["greedy", "random:1"]


@pytest.mark.parametrize(("remote", "section", "field", "value", "shown"), [
    (False, "options", "max_steps", 20, "max_steps (null vs 20)"),
    (False, "options", "stable_ids", True, "stable_ids (false vs true)"),
    (True, "model_settings", "temperature", 0.7, 'temperature ("auto" vs 0.7)'),
    (True, "model_settings", "grammar", True, "grammar (false vs true)"),
    (True, "model_settings", "api_base", "http://127.0.0.1:9/v1", "api_base"),
])
def test_a_row_of_runs_that_differ_is_refused(tmp_path, remote, section, field, value, shown):
    a = run_copy(tmp_path / "a", remote=remote)
    b = run_copy(tmp_path / "b", remote=remote, **{f"{section}__{field}": value})
    with pytest.raises(ReportError) as caught:
        load_runs([a, b])
    message = str(caught.value)
    assert str(a) in message and str(b) in message and shown in message
    assert "--arms" in message


def test_model_settings_do_not_split_builtin_models(tmp_path):
    # greedy sends nothing anywhere: another temperature cannot change its episodes.
    a = run_copy(tmp_path / "a")
    b = run_copy(tmp_path / "b", model_settings__temperature=0.7)
    assert load_runs([a, b]).models == ["greedy", "random:1"]


def test_the_cli_refuses_in_one_line_and_arms_keep_runs_apart(tmp_path, capsys):
    a = run_copy(tmp_path / "t0", remote=True)
    b = run_copy(tmp_path / "t07", remote=True, model_settings__temperature=0.7)
    code = main(["report", str(a), str(b), "--out", str(tmp_path / "report"), "--no-plots",
                 "--resamples", "20"])
    err = capsys.readouterr().err
    assert code == 2 and "temperature" in err and "Traceback" not in err
    assert not (tmp_path / "report").exists()  # nothing written
    code = main(["report", str(a), str(b), "--out", str(tmp_path / "report"), "--no-plots",
                 "--resamples", "20", "--arms"])
    assert code == 0
    data = load_runs([a, b], arms=True)
    assert data.models == [f"{REMOTE} @{a}", f"{REMOTE} @{b}"]
    assert data.superseded_across_runs == 0
    assert f"{REMOTE} @{b}" in (tmp_path / "report" / "main_results.md").read_text()


def test_runs_whose_teams_differ_are_not_one_row(tmp_path, capsys):
    from cocobench_agents.cli import main

    common = ["run", "--suite", "demo", "--only-cell", "G_D1", "--model", "greedy",
              "--conditions", "D1_blind", "--max-steps", "2"]
    assert main([*common, "--out", str(tmp_path / "team")]) == 0
    assert main([*common, "--agent-model", "agent_2=random:1",
                 "--out", str(tmp_path / "mixed")]) == 0
    capsys.readouterr()
    assert main(["report", str(tmp_path / "team"), str(tmp_path / "mixed"), "--out",
                 str(tmp_path / "report"), "--no-plots"]) == 2
    assert "differ in agent_models" in capsys.readouterr().err
