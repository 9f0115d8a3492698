"""Where a Ray run's episodes ran: the ``node`` and ``requeued`` fields of its result lines are
valid result fields that survive a resume and a report unchanged, and `node_lines` says how
many episodes each node ran and how many of them were re-queued."""

from __future__ import annotations

import json
import shutil

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    pending_episodes,
    plan_episodes,
)
from cocobench_agents.models import ModelPool
from cocobench_agents.reports.build import compute_tables
from cocobench_agents.reports.load import load_runs
from cocobench_agents.runfolder import RunFolder
from cocobench_agents.runfolder.result_line import line_error
from cocobench_agents.runfolder.summary import node_lines, summary_table

NODE_A, NODE_B = "a" * 56, "b" * 56


def test_node_lines_count_episodes_and_requeues_per_node():
    records = [{"model": "m", "condition": "C0_blind", "task_id": f"t{i}", "epoch": 0,
                "task_success": 0, "node": NODE_A if i < 3 else NODE_B} for i in range(5)]
    records[1]["requeued"] = 1
    retried = {**records[4], "node": NODE_A}  # a later line for the same episode wins
    assert node_lines([*records, retried]) == [
        f"node {NODE_A}: 4 episodes, 1 of them re-queued from a lost worker",
        f"node {NODE_B}: 1 episode"]
    local = [{k: v for k, v in r.items() if k not in ("node", "requeued")} for r in records]
    assert node_lines(local) == []


def test_node_fields_are_valid_and_survive_resume_and_report(tmp_path):
    planned = plan_episodes(load_tasks("demo"), ["random:7"],
                            [Condition("centralized", "blind")], 1)
    local = RunFolder(tmp_path / "local")
    local.create({"name": "local"})
    InProcess().run(planned, local, ModelPool(), ExecutionSettings(jobs=2))
    shutil.copytree(local.path, tmp_path / "ray")
    ray = RunFolder(tmp_path / "ray")
    lines = [json.loads(line) for line in (ray.path / "results.jsonl").read_text().splitlines()]
    lines[0]["requeued"] = 1
    (ray.path / "results.jsonl").write_text(
        "".join(json.dumps({**line, "node": NODE_A}) + "\n" for line in lines))

    assert all(line_error(line) is None for line in ray.results())
    assert pending_episodes(planned, ray) == []  # a resume runs nothing again
    assert summary_table(ray.results()) == summary_table(local.results())
    assert compute_tables(load_runs([ray.path])) == compute_tables(load_runs([local.path]))
    assert node_lines(ray.results()) == [
        f"node {NODE_A}: {len(planned)} episodes, 1 of them re-queued from a lost worker"]
