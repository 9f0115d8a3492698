"""A run of built-in planners never imports LangGraph (nor langchain-core, langsmith): their
rounds are awaited directly (`graphs.rounds.play_rounds`), and importing LangGraph was about
half of a run's serial start. A strategy that gives only a graph still runs through it.

Observed with the interpreter's ``-X importtime``: every module any process of the run
imports is a line on the run's stderr, the worker processes' too (forked, they keep the
setting and start from the driver's modules)."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

from cocobench_agents.graphs.runtime import END, RoundRuntime

LANGGRAPH_PACKAGES = ("langgraph", "langchain_core", "langsmith")
STRATEGIES = Path(__file__).resolve().parents[2] / "examples" / "strategies"
RUN = [sys.executable, "-X", "importtime", "-m", "cocobench_agents.cli", "run", "--suite",
       "demo", "--model", "greedy", "--limit", "2", "--workers", "2"]

GRAPH_ONLY = '''
from cocobench_agents.graphs import PlannerSpec, lazy_builder

GRAPH_ONLY = PlannerSpec(
    "graph-only", "GO", lazy_builder("cocobench_agents.graphs.centralized:build_centralized"),
    False, True, "the centralized round given only as its graph", loop="step", prompt="team")
'''


def imported_packages(stderr: str) -> set[str]:
    """The top-level packages of every module `-X importtime` logged."""
    return {line.rpartition("|")[2].strip().split(".")[0]
            for line in stderr.splitlines() if line.startswith("import time:")}


def run(tmp_path: Path, *planner_args: str) -> tuple[set[str], list[dict]]:
    out = tmp_path / "run"
    done = subprocess.run([*RUN, *planner_args, "--out", str(out)], capture_output=True,
                          text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = (out / "results.jsonl").read_text().splitlines()
    return imported_packages(done.stderr), [json.loads(line) for line in lines]


@pytest.mark.slow
def test_a_run_of_the_built_in_planners_imports_no_langgraph(tmp_path):
    packages, results = run(tmp_path, "--planner", "centralized", "--planner",
                            "decentralized-broadcast", "--planner", "leader-worker",
                            "--baselines")
    assert {"cocobench_agents", "benchmark_adapter"} <= packages  # the log saw the run
    assert packages.isdisjoint(LANGGRAPH_PACKAGES), packages & set(LANGGRAPH_PACKAGES)
    assert sorted({r["condition"].split("_")[0] for r in results}) == ["C0", "D1", "LW", "OR"]
    assert all(r["terminal_reason"] for r in results)


@pytest.mark.slow
def test_the_example_strategies_rounds_run_without_langgraph(tmp_path):
    # What a researcher copies: rounds declared, LangGraph's types for type checking only.
    packages, results = run(tmp_path, "--planner", f"{STRATEGIES}/sealed_bid.py:SEALED_BID",
                            "--planner", f"{STRATEGIES}/first_come.py:FIRST_COME")
    assert packages.isdisjoint(LANGGRAPH_PACKAGES), packages & set(LANGGRAPH_PACKAGES)
    assert sorted({r["condition"] for r in results}) == ["FC_image", "SB_image"]


@pytest.mark.slow
def test_a_strategy_that_gives_only_a_graph_runs_through_langgraph(tmp_path):
    (tmp_path / "graph_only.py").write_text(GRAPH_ONLY)
    packages, results = run(tmp_path, "--planner", "graph_only.py:GRAPH_ONLY")
    assert "langgraph" in packages
    assert [r["condition"] for r in results] == ["GO_image"] * 2
    assert all(r["terminal_reason"] for r in results)


def test_the_end_of_a_round_is_langgraphs_end():
    from langgraph.graph import END as LANGGRAPH_END

    assert END == LANGGRAPH_END


def test_the_plain_loops_runtime_has_langgraphs_fields_and_defaults():
    from langgraph.runtime import Runtime

    assert RoundRuntime(context="ctx").context == Runtime(context="ctx").context == "ctx"
    theirs = {f.name for f in dataclasses.fields(Runtime)}
    for field in dataclasses.fields(RoundRuntime):
        assert field.name in theirs
        ours, default = getattr(RoundRuntime(), field.name), getattr(Runtime(), field.name)
        if callable(default):  # a no-op writer: writes nothing anywhere, returns nothing
            assert ours({"chunk": 1}) is default({"chunk": 1}) is None
        else:
            assert ours == default
