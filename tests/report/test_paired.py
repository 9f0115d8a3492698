"""The arms table: every arm side by side and its paired difference from the first arm, over
the instances both arms have, checked against sums done by hand over results.jsonl; one plot
per metric; and no such table (the golden report unchanged) for runs without arms."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.reports import ReportError, build_report, load_runs

from .helpers import RUN_ARMS, RUN_ORACLE, RUN_ORACLE_SHORT, RUN_SMALL, result_lines, write_run

BASE, NO_HINT = "cocobench-v1", "cocobench-v1+no-hint"


def arms_csv(out: Path) -> dict[tuple[str, str, str], dict[str, str]]:
    text = (out / "arms.csv").read_text(encoding="utf-8")
    return {(r["model"], r["condition"], r["arm"]): r for r in csv.DictReader(io.StringIO(text))}


def by_instance(lines: list[dict], model: str, arm: str) -> dict[tuple[str, int], dict]:
    return {(r["task_id"], r["epoch"]): r for r in lines
            if r["model"] == model and r.get("arm") == arm}


def test_the_paired_differences_are_the_hand_computed_ones(tmp_path):
    out = tmp_path / "report"
    build_report([RUN_ARMS], out, plots=False)
    rows = arms_csv(out)
    lines = result_lines(RUN_ARMS)
    assert len(lines) == 31  # the fixture's last episode is missing: random:1, no-hint
    for model in ("greedy", "random:1"):
        base, other = by_instance(lines, model, BASE), by_instance(lines, model, NO_HINT)
        shared = sorted(base.keys() & other.keys())
        assert len(shared) == (8 if model == "greedy" else 7)
        success = [other[i]["task_success"] - base[i]["task_success"] for i in shared]
        scored = [other[i]["construct_score"] - base[i]["construct_score"] for i in shared
                  if other[i]["construct_score"] is not None
                  and base[i]["construct_score"] is not None]
        delta = rows[model, "C0_image", f"{NO_HINT} - {BASE}"]
        assert delta["baseline"] == BASE
        assert int(delta["n"]) == int(delta["sr_n"]) == len(shared)
        assert float(delta["sr"]) == pytest.approx(100 * sum(success) / len(success), abs=5e-5)
        assert int(delta["cs_n"]) == len(scored)
        assert float(delta["cs"]) == pytest.approx(sum(scored) / len(scored), abs=5e-5)
        assert float(delta["cs_lo"]) <= float(delta["cs"]) <= float(delta["cs_hi"])
        for arm, episodes in ((BASE, base), (NO_HINT, other)):  # each arm on its own row
            row = rows[model, "C0_image", arm]
            assert row["baseline"] == "" and int(row["n"]) == len(episodes)
    # random:1 was sampled differently under each arm: its construct scores differ
    random_delta = rows["random:1", "C0_image", f"{NO_HINT} - {BASE}"]
    assert float(random_delta["cs"]) != 0.0
    assert float(random_delta["cs_lo"]) < float(random_delta["cs_hi"])


def test_runs_given_with_arms_are_paired_the_same_way(tmp_path):
    """The oracle with its full budget (4 of 4 successful) and cut to 8 steps (1 of 4)."""
    out = tmp_path / "report"
    build_report([RUN_ORACLE, RUN_ORACLE_SHORT], out, plots=False, arms=True)
    full = {r["task_id"]: r["task_success"] for r in result_lines(RUN_ORACLE)}
    short = {r["task_id"]: r["task_success"] for r in result_lines(RUN_ORACLE_SHORT)}
    assert sum(full.values()) == 4 and sum(short.values()) == 1
    expected = sum(short[t] - full[t] for t in full) / len(full)  # (1 - 4) / 4
    assert expected == -0.75
    row = arms_csv(out)["oracle", "OR_image", f"{RUN_ORACLE_SHORT} - {RUN_ORACLE}"]
    assert float(row["sr"]) == -75.0 and int(row["n"]) == 4
    assert float(row["sr_lo"]) <= -75.0 <= float(row["sr_hi"]) <= 0.0
    assert "Arms: paired differences" in (out / "index.md").read_text()


def test_the_arms_table_is_in_the_index_with_one_plot_per_metric(tmp_path):
    out = tmp_path / "report"
    summary = build_report([RUN_ARMS], out)
    index = (out / "index.md").read_text()
    assert "* [Arms: paired differences](arms.md) ([CSV](arms.csv))" in index
    for figure in ("fig_arms_sr.png", "fig_arms_cs.png"):
        assert (out / figure).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert figure in index and out / figure in summary.files
    markdown = (out / "arms.md").read_text()
    assert f"| random:1 | C0_image  | {NO_HINT} - {BASE} |   7 |" in markdown
    assert "Baseline" not in markdown  # a CSV-only column


def test_arms_are_separate_rows_in_every_table():
    data = load_runs([RUN_ARMS])
    assert data.models == [f"greedy @{BASE}", f"greedy @{NO_HINT}", f"random:1 @{BASE}",
                           f"random:1 @{NO_HINT}"]
    assert data.model_arms[f"random:1 @{NO_HINT}"] == ("random:1", NO_HINT)
    assert len(data.episodes) == 31
    assert data.runs[0].planned == 32  # the plan counts each arm


def test_runs_without_arms_have_no_arms_table(tmp_path):
    build_report([RUN_SMALL, RUN_ORACLE], tmp_path / "r", plots=False)
    assert not (tmp_path / "r" / "arms.md").exists()
    assert "Arms" not in (tmp_path / "r" / "index.md").read_text()


def test_an_arm_of_two_runs_merges_only_with_the_same_suite(tmp_path):
    """Two runs of the same arms merge per arm; an arm whose suite's content differs
    between them is refused, naming the setting."""
    record = json.loads((RUN_ARMS / "run.json").read_text())
    write_run(tmp_path / "a", result_lines(RUN_ARMS))
    (tmp_path / "a" / "run.json").write_text(json.dumps(record))
    data = load_runs([RUN_ARMS, tmp_path / "a"])
    assert data.superseded_across_runs == 31
    record["prompt_suites"][1]["content_hash"] = "0" * 64
    (tmp_path / "a" / "run.json").write_text(json.dumps(record))
    with pytest.raises(ReportError, match=r"prompt_suite content"):
        load_runs([RUN_ARMS, tmp_path / "a"])
    assert main(["report", str(RUN_ARMS), str(tmp_path / "a"), "--out",
                 str(tmp_path / "r")]) == 2
