"""The Python API: `evaluate` runs what `cocobench run` runs (docs/python-api.md's examples
run as written in tests/test_docs.py)."""

from __future__ import annotations

import asyncio
import json
import warnings
from pathlib import Path

import pytest

import cocobench_agents as cb
from cocobench_agents.cli import main


def test_evaluate_equals_the_command(tmp_path):
    assert main(["run", "--suite", "demo", "--model", "random:3", "--conditions",
                 "C0_image,D0_blind", "--max-steps", "6", "--out", str(tmp_path / "cli")]) == 0
    results = cb.evaluate("demo", models="random:3", conditions="C0_image,D0_blind",
                          max_steps=6, out=tmp_path / "api")

    def lines(folder: Path) -> list[dict]:
        out = []
        for line in (folder / "results.jsonl").read_text().splitlines():
            record = json.loads(line)
            record.pop("elapsed_s")
            out.append(record)
        return out

    assert lines(tmp_path / "api") == lines(tmp_path / "cli")
    assert [r["task_id"] for r in results] == [r["task_id"] for r in lines(tmp_path / "cli")]
    for record in lines(tmp_path / "cli"):
        a = (tmp_path / "api" / record["trajectory"]).read_text()
        assert a == (tmp_path / "cli" / record["trajectory"]).read_text()


def test_errors_are_counted_and_warned(tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        results = cb.evaluate("demo", models="openai/never", out=tmp_path / "r", max_steps=2,
                              api_base="http://127.0.0.1:9/v1", timeout=0.5, max_retries=0,
                              no_preflight=True, transport="http")
    assert results.errors == 4
    assert any("infrastructure errors" in str(w.message) for w in caught)


def test_unknown_options_and_mistakes_are_refused(tmp_path):
    with pytest.raises(TypeError, match="'bogus'"):
        cb.evaluate("demo", models="greedy", out=tmp_path / "a", bogus=1)
    with pytest.raises(cb.EvaluationError, match="unknown condition"):
        cb.evaluate("demo", models="greedy", out=tmp_path / "b", conditions="C9_image")
    assert not (tmp_path / "b").exists()


def test_evaluate_async_runs_inside_an_event_loop(tmp_path):
    async def notebook_cell():
        return await cb.evaluate_async("demo", models="greedy", out=tmp_path / "r",
                                       max_steps=2)

    assert len(asyncio.run(notebook_cell())) == 4


def test_evaluate_runs_prompt_suite_and_planner_arms_as_the_command_does(tmp_path):
    suites = ["cocobench-v1", "cocobench-v1+no-hint"]
    results = cb.evaluate("demo", models="random:3", planners=["centralized", "leader-worker"],
                          prompt_suites=suites, max_steps=4, out=tmp_path / "api")
    assert len(results) == 4 * 2 * 2 and results.errors == 0
    cells = {(r["condition"], r["arm"]) for r in results}
    assert cells == {(c, s) for c in ("C0_image", "LW_image") for s in suites}
    assert all(r["prompt_suite"] == r["arm"] for r in results)
    assert main(["run", "--suite", "demo", "--model", "random:3", "--planner", "centralized",
                 "--planner", "leader-worker", "--obs", "image", "--prompt-suite", suites[0],
                 "--prompt-suite", suites[1], "--max-steps", "4",
                 "--out", str(tmp_path / "cli")]) == 0

    def lines(folder: Path) -> list[dict]:
        records = [json.loads(line) for line in (folder / "results.jsonl").read_text()
                   .splitlines()]
        return sorted(({k: v for k, v in r.items() if k != "elapsed_s"} for r in records),
                      key=lambda r: (r["condition"], r["arm"], r["task_id"]))

    assert lines(tmp_path / "api") == lines(tmp_path / "cli")
    import cocobench_agents.reports  # noqa: F401 - the subpackage must not shadow cb.report

    written = cb.report(tmp_path / "api", tmp_path / "report", plots=False)
    assert "arms" in [t.name for t in written.tables]
