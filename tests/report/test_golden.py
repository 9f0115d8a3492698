"""Golden files: the Markdown and CSV report of the fixed run folders, byte for byte.

Regenerate after an intended change with `COCOBENCH_UPDATE_GOLDENS=1 python -m pytest
tests/report/test_golden.py`, then review the diff of tests/report/golden/ before committing.
"""

from __future__ import annotations

import csv
import io
import os
import shutil
from pathlib import Path

import pytest

from cocobench_agents.reports import build_report

from .helpers import GOLDEN, RUN_ORACLE, RUN_SMALL, result_lines

UPDATE = os.environ.get("COCOBENCH_UPDATE_GOLDENS") == "1"
CASES = {"run_small": [RUN_SMALL], "merged": [RUN_SMALL, RUN_ORACLE]}


def _report(runs: list[Path], out: Path) -> dict[str, bytes]:
    build_report(runs, out, plots=False)
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix in (".md", ".csv")}


@pytest.mark.parametrize("case", sorted(CASES))
def test_report_matches_golden_files(case: str, tmp_path: Path) -> None:
    produced = _report(CASES[case], tmp_path / "report")
    golden = GOLDEN / case
    if UPDATE:
        shutil.rmtree(golden, ignore_errors=True)
        golden.mkdir(parents=True)
        for name, data in produced.items():
            (golden / name).write_bytes(data)
    expected = {p.name: p.read_bytes() for p in sorted(golden.iterdir())}
    assert sorted(produced) == sorted(expected)
    for name, data in produced.items():
        assert data == expected[name], (
            f"{case}/{name} differs from its golden file: review the change, then regenerate "
            "with COCOBENCH_UPDATE_GOLDENS=1")


def _csv(name: str, case: str = "run_small") -> dict[tuple[str, str], dict[str, str]]:
    """A golden CSV's rows by (model, condition)."""
    text = (GOLDEN / case / name).read_text(encoding="utf-8")
    return {(r["model"], r["condition"]): r for r in csv.DictReader(io.StringIO(text))}


def _mean(values: list[float]) -> float:
    return sum(values) / len(values)


def test_golden_numbers_match_a_direct_computation() -> None:
    """The reviewed golden CSVs agree with plain Python over results.jsonl."""
    lines = result_lines(RUN_SMALL)
    main, diag, cost = _csv("main_results.csv"), _csv("failure_diagnostics.csv"), _csv("cost.csv")
    assert len(main) == 12
    for (model, condition), row in main.items():
        eps = [e for e in lines if e["model"] == model and e["condition"] == condition]
        assert int(row["n"]) == len(eps) == 4
        assert float(row["sr"]) == pytest.approx(100 * _mean([e["task_success"] for e in eps]))
        scored = [e["construct_score"] for e in eps if e["construct_score"] is not None]
        assert int(row["cs_n"]) == len(scored)
        if scored:
            assert float(row["cs"]) == pytest.approx(_mean(scored), abs=5e-5)
            assert float(row["cs_lo"]) <= float(row["cs"]) <= float(row["cs_hi"])
        else:
            assert row["cs"] == row["cs_lo"] == row["cs_hi"] == ""
        for dim in ("D1", "D2", "D3", "D4"):
            in_dim = [e for e in eps if e["dim"] == dim]
            assert int(row[f"{dim.lower()}_sr_n"]) == len(in_dim)
        failed = [e for e in eps if not e["task_success"]]
        d = diag[model, condition]
        assert int(d["failed"]) == len(failed)
        assert float(d["progress_fail"]) == pytest.approx(
            100 * _mean([e["task_progress"] for e in failed]), abs=5e-5)
        assert float(d["invalid_ratio"]) == pytest.approx(
            100 * _mean([e["num_invalid_action_ratio"] for e in eps]), abs=5e-5)
        assert float(d["dep"]) == pytest.approx(
            100 * _mean([float(e["dependency_violations"] > 0) for e in failed]), abs=5e-5)
        c = cost[model, condition]
        assert float(c["elapsed_s_total"]) == pytest.approx(sum(e["elapsed_s"] for e in eps),
                                                            abs=5e-5)
        assert float(c["steps"]) == pytest.approx(_mean([e["num_steps"] for e in eps]))


def test_hand_checked_cells() -> None:
    """A few cells checked by hand against results.jsonl (see the review notes in
    docs/reports.md): random:1 under C0_image scored 4 of 4 construct scores
    (G_D1 1/3, K_D3 0.75, C_D2 0.5, J_D4 0.5: mean 0.5208)."""
    row = _csv("main_results.csv")["random:1", "C0_image"]
    assert (row["cs"], row["cs_n"]) == ("0.5208", "4")
    assert (row["d3_cs"], row["d3_cs_lo"], row["d3_cs_hi"]) == ("0.7500", "0.7500", "0.7500")
    md = (GOLDEN / "run_small" / "main_results.md").read_text(encoding="utf-8")
    assert "| random:1 | C0_image  |   4 | 0.0 [0.0, 0.0] | 0.52 [" in md
    # greedy under C0_image failed all 4 episodes; progress 0.25 on C_D2 only: 6.25 %.
    assert _csv("failure_diagnostics.csv")["greedy", "C0_image"]["progress_fail"] == "6.2500"
    # the oracle's 4 episodes all succeed with legal plans
    legal = _csv("legality.csv", "merged")
    assert legal["oracle", "OR_image"]["sr"] == legal["oracle", "OR_image"]["legal"] == "100.0000"
