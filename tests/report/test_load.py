"""Reading run folders: torn lines, infrastructure failures, retries, merging runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cocobench_agents.reports import NotARunFolder, build_report, compute_tables, load_runs
from cocobench_agents.reports.load import RunInfo
from cocobench_agents.reports.render import to_csv
from cocobench_agents.runfolder.upgrade import RECORD_VERSION

from .helpers import (
    NOT_RUN_FOLDERS,
    RUN_ORACLE,
    RUN_SMALL,
    not_a_run_folder,
    result_lines,
    write_run,
)


def _tables(*runs: Path) -> dict[str, object]:
    return {t.name: t for t in compute_tables(load_runs(list(runs)))}


def _row(table, **match):
    row = table.find(**match)
    assert row is not None, match
    return row


def test_fixture_reads_as_48_episodes() -> None:
    data = load_runs([RUN_SMALL])
    assert len(data.episodes) == 48
    assert data.models == ["greedy", "random:1"]
    assert data.conditions == ["C0_image", "C0_blind", "D0_image", "D0_blind", "D1_image",
                               "D1_blind"]
    assert data.architectures() == ["C0", "D0", "D1"] and data.obs_modes() == ["image", "blind"]
    run = data.runs[0]
    assert (run.name, run.lines, run.episodes, run.planned, run.torn_tail) == (
        "run_small", 48, 48, 48, False)


def test_torn_last_line_is_skipped(small_copy: Path, tmp_path: Path) -> None:
    extra = dict(result_lines(RUN_SMALL)[0], epoch=1, task_success=1)
    with open(small_copy / "results.jsonl", "a", encoding="utf-8") as f:
        f.write(json.dumps(extra)[:200])  # a kill in the middle of a write: no newline
    data = load_runs([small_copy])
    assert len(data.episodes) == 48 and data.runs[0].torn_tail
    summary = build_report([small_copy], tmp_path / "out", plots=False)
    index = (tmp_path / "out" / "index.md").read_text(encoding="utf-8")
    assert summary.episodes == 48 and "incomplete last line skipped" in index
    # the tables are those of the intact run
    assert (tmp_path / "out" / "main_results.csv").read_text(encoding="utf-8") == to_csv(
        _tables(RUN_SMALL)["main_results"])


def _infra_line(base: dict, **changes) -> dict:
    keys = ("model", "condition", "task_id", "epoch", "cell", "family", "dim",
            "agent_count", "planner", "obs_mode", "backend", "prompt_suite")
    line = {k: base[k] for k in keys}
    line.update({"infra_error": "RuntimeError('simulator crashed')", "task_success": 0,
                 "legal_plan": 0, "elapsed_s": 0.5}, **changes)
    return line


def test_infra_error_counts_as_a_failure_without_diagnostics(tmp_path: Path) -> None:
    lines = [line for line in result_lines(RUN_SMALL) if line["model"] == "greedy"]
    oracle = result_lines(RUN_ORACLE)  # successes, so a failure shows in SR
    infra = _infra_line(oracle[0], epoch=1)
    run = write_run(tmp_path / "run", [*lines, *oracle, infra])
    tables = _tables(run)
    main = _row(tables["main_results"], model="oracle", condition="OR_image")
    assert main["n"] == 5 and main["sr"].value == pytest.approx(0.8) and main["sr"].n == 5
    assert main["cs"].n == 4  # no construct score for the episode that did not run
    kinds = _row(tables["terminal_states"], model="oracle", condition="OR_image")
    assert kinds["infra_error"].value == pytest.approx(0.2)
    assert kinds["success"].value == pytest.approx(0.8)
    diag = _row(tables["failure_diagnostics"], model="oracle", condition="OR_image")
    assert diag["failed"] == 1
    assert diag["progress_fail"].na and diag["dep"].na  # nothing known about its trajectory
    legal = _row(tables["legality"], model="oracle", condition="OR_image")
    assert legal["legal"].n == 5 and legal["legal"].value == pytest.approx(0.8)
    cost = _row(tables["cost"], model="oracle", condition="OR_image")
    assert cost["elapsed_s"].n == 5 and cost["steps"].n == 4
    data = load_runs([run])
    assert data.runs[0].infra_errors == 1
    build_report([run], tmp_path / "out", plots=False)
    index = (tmp_path / "out" / "index.md").read_text(encoding="utf-8")
    assert "1 of 29 episodes ended on an infrastructure error" in index
    assert "--resume --retry-errors" in index


def test_the_terminal_states_caption_explains_every_column_shown(tmp_path: Path) -> None:
    oracle = result_lines(RUN_ORACLE)
    planner = _infra_line(oracle[1], epoch=1, infra_error=None,
                          planner_error="ValueError('a node raised')")
    run = write_run(tmp_path / "run", [*result_lines(RUN_SMALL), *oracle,
                                       _infra_line(oracle[0], epoch=1), planner])
    table = _tables(run)["terminal_states"]
    kinds = [c.key for c in table.columns if c.key not in ("model", "condition", "n")]
    assert {"infra_error", "planner_error"} <= set(kinds)
    unexplained = [k for k in kinds if k != "success" and f"{k} = " not in table.caption]
    assert not unexplained, table.caption


def test_an_imported_runs_errors_are_retried_through_inspect(tmp_path: Path) -> None:
    """`cocobench run --resume` cannot resume a run imported from an Inspect log: the
    report's advice is Inspect's retry of that log, then an import of the new log."""
    record = json.loads((RUN_ORACLE / "run.json").read_text(encoding="utf-8"))
    record["imported_from"] = {"inspect_log": "/logs/my eval.eval", "status": "error",
                               "retry": "rm -rf ~"}  # the folder's text is never shown
    (tmp_path / "run.json").write_text(json.dumps(record), encoding="utf-8")
    oracle = result_lines(RUN_ORACLE)
    run = write_run(tmp_path / "run", [*oracle, _infra_line(oracle[0], epoch=1)],
                    run_json=tmp_path / "run.json")
    build_report([run], tmp_path / "out", plots=False)
    index = (tmp_path / "out" / "index.md").read_text(encoding="utf-8")
    assert "inspect eval-retry '/logs/my eval.eval', then cocobench import-inspect" in index
    assert "--retry-errors" not in index and "rm -rf" not in index


def test_a_later_line_supersedes_an_earlier_one(tmp_path: Path) -> None:
    oracle = result_lines(RUN_ORACLE)
    first = _infra_line(oracle[0])
    run = write_run(tmp_path / "run", [first, *oracle])  # the retry succeeded
    data = load_runs([run])
    assert len(data.episodes) == 4 and data.runs[0].superseded == 1
    assert data.runs[0].infra_errors == 0
    main = _row(_tables(run)["main_results"], model="oracle")
    assert main["sr"].value == 1.0
    # and the other way round: a failed retry replaces a success
    run2 = write_run(tmp_path / "run2", [*oracle, first])
    assert _row(_tables(run2)["main_results"], model="oracle")["sr"].value == pytest.approx(0.75)


def test_two_runs_side_by_side() -> None:
    data = load_runs([RUN_SMALL, RUN_ORACLE])
    assert data.models == ["greedy", "random:1", "oracle"]
    assert data.conditions[-1] == "OR_image" and len(data.episodes) == 52
    assert data.superseded_across_runs == 0
    tables = _tables(RUN_SMALL, RUN_ORACLE)
    assert [r["model"] for r in tables["main_results"].records()].count("oracle") == 1
    alone = _tables(RUN_SMALL)
    for name in ("main_results", "legality", "cost"):  # the first run's rows are unchanged
        assert to_csv(tables[name]).startswith(to_csv(alone[name]).rstrip("\n"))


def test_same_model_in_two_runs_is_merged(tmp_path: Path) -> None:
    lines = result_lines(RUN_SMALL)
    a = write_run(tmp_path / "a", lines[:30], RUN_SMALL / "run.json")
    b = write_run(tmp_path / "b", lines[30:], RUN_SMALL / "run.json")
    merged, whole = _tables(a, b), _tables(RUN_SMALL)
    for name, table in whole.items():
        assert to_csv(merged[name]) == to_csv(table), name


def test_later_run_wins_on_duplicate_episodes(tmp_path: Path) -> None:
    oracle = result_lines(RUN_ORACLE)
    failed = [dict(line, task_success=0) for line in oracle[:2]]
    a = write_run(tmp_path / "a", oracle)
    b = write_run(tmp_path / "b", failed)
    data = load_runs([a, b])
    assert len(data.episodes) == 4 and data.superseded_across_runs == 2
    assert _row(_tables(a, b)["main_results"], model="oracle")["sr"].value == 0.5
    assert _row(_tables(b, a)["main_results"], model="oracle")["sr"].value == 1.0


def test_run_in_progress_without_results(tmp_path: Path) -> None:
    run = tmp_path / "starting"
    run.mkdir()
    (run / "run.json").write_text((RUN_SMALL / "run.json").read_text(encoding="utf-8"),
                                  encoding="utf-8")
    summary = build_report([run], tmp_path / "out")
    assert summary.episodes == 0 and summary.plots == []
    assert "_No episodes._" in (tmp_path / "out" / "main_results.md").read_text(
        encoding="utf-8")
    assert "0/48" in (tmp_path / "out" / "index.md").read_text(encoding="utf-8")


def test_run_in_progress_reports_what_is_complete(tmp_path: Path) -> None:
    lines = result_lines(RUN_SMALL)[:10]
    run = write_run(tmp_path / "run", lines, RUN_SMALL / "run.json")
    build_report([run], tmp_path / "out", plots=False)
    assert "10/48" in (tmp_path / "out" / "index.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("make", NOT_RUN_FOLDERS)
def test_not_a_run_folder(tmp_path: Path, make: str) -> None:
    path = not_a_run_folder(tmp_path / "x", make)
    with pytest.raises(NotARunFolder, match="x"):
        load_runs([path])


def test_every_terminal_state_a_report_shows_is_explained_in_its_docs():
    """A kind of ending the loader gives an episode beside the benchmark's (`infra_error`, a
    strategy's `planner_error`, `unrecorded`) is named in docs/reports.md, as the README's
    paragraph on errors names the planner error."""
    from benchmark_adapter.metrics import FAILURE_KINDS
    from cocobench_agents.reports.load import INFRA_KIND, PLANNER_KIND, UNRECORDED_KIND

    root = Path(__file__).resolve().parents[2]
    reports = (root / "docs" / "reports.md").read_text()
    for kind in (*FAILURE_KINDS, INFRA_KIND, PLANNER_KIND, UNRECORDED_KIND):
        assert f"`{kind}`" in reports, kind
    assert "planner error" in (root / "README.md").read_text()


@pytest.mark.parametrize("epochs", [[[1]], "3", True, -2, 2.5, {"n": 1}])
@pytest.mark.parametrize("where", ["plan", "request"])
def test_a_plan_in_a_shape_no_run_writes_plans_nothing(epochs, where) -> None:
    """What run.json says it planned is read only in the shapes a run writes: epochs a
    positive integer, the plan's names lists (CI's run-folder fuzz found a nested list as
    the request's epochs crashing `cocobench report`)."""
    plan = {"task_ids": ["t1", "t2"], "models": ["greedy"], "conditions": ["C0_blind"]}
    record = {"plan": {**plan, "epochs": epochs}} if where == "plan" else \
        {"record_version": RECORD_VERSION, "plan": plan, "request": {"epochs": epochs}}
    run = RunInfo(path=Path("run"), name="run", record=record, lines=0, torn_tail=False,
                  episodes=0, infra_errors=0)
    assert run.planned is None
    good = RunInfo(path=Path("run"), name="run", record={"plan": {**plan, "epochs": 3}},
                   lines=0, torn_tail=False, episodes=0, infra_errors=0)
    assert good.planned == 6


@pytest.mark.parametrize("plan", [[1, 2], "plan", 7, {"task_ids": "t1", "models": 3,
                                                     "conditions": None, "arms": 5}])
def test_a_plan_of_another_shape_names_no_models_or_conditions(plan) -> None:
    run = RunInfo(path=Path("run"), name="run", record={"plan": plan}, lines=0,
                  torn_tail=False, episodes=0, infra_errors=0)
    assert (run.models, run.conditions, run.arms, run.planned) == ([], [], [], None)
